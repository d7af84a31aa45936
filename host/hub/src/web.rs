//! The head office's pages: the stores, a store's sessions, one session
//! (its readings, the sizes of its estimate, and the body in a 3D viewer),
//! and the vendored three.js files the viewer loads.
//!
//! Why plain server-rendered HTML: three short pages with tables need no
//! front-end build. Every value from a station (a customer id, a note, a
//! measurement name) is escaped with [`escape`] before it is written into
//! a page. The viewer is three.js (MIT, `assets/three/`, served by the hub
//! itself at `/static/three/`: no CDN), loading the session's GLB from the
//! hub with the same password.

use axum::http::header;
use axum::response::{IntoResponse, Response};

use crate::db::{SessionFull, SessionRow, StationRow};

/// Escapes text for HTML element content and attribute values. Written
/// here (five replacements) rather than taken from a crate: it is the whole
/// of what the pages need.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// A page as a response (no caching: the pages show personal data).
pub fn html(body: String) -> Response {
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (header::CACHE_CONTROL, "private, no-store"),
        ],
        body,
    )
        .into_response()
}

fn page(title: &str, body: &str) -> String {
    format!(
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>{} - tapeshape hub</title>\
         <style>body{{font-family:sans-serif;margin:1.5em;color:#222;background:#fff}}\
         table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:.2em .6em;text-align:left}}\
         td.n{{text-align:right}}.dim{{color:#777}}#viewer{{border:1px solid #ccc}}</style>\
         </head><body>{}</body></html>\n",
        escape(title),
        body
    )
}

fn time_ms(ms: i64) -> String {
    // UTC, minutes: `YYYY-MM-DD HH:MM` from days since the epoch (the civil
    // calendar's arithmetic; a date crate would be a dependency for one line).
    let secs = ms.div_euclid(1000);
    let days = secs.div_euclid(86_400);
    let rem = secs.rem_euclid(86_400);
    let (y, m, d) = civil_from_days(days);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02}",
        rem / 3600,
        (rem % 3600) / 60
    )
}

/// Days since 1970-01-01 to (year, month, day) in the proleptic Gregorian
/// calendar (H. Hinnant's algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { y + 1 } else { y }, m, d)
}

fn cm(tenth_mm: i64) -> String {
    format!("{:.1} cm", tenth_mm as f64 / 100.0)
}

/// `/`: every store with its counts.
pub fn index_page(stations: &[StationRow]) -> String {
    let mut rows = String::new();
    for s in stations {
        rows.push_str(&format!(
            "<tr><td><a href=\"/stores/{n}\">{n}</a></td><td class=n>{}</td><td class=n>{}</td>\
             <td class=n>{}</td><td>{}</td></tr>",
            s.sessions,
            s.readings,
            s.last_seq,
            if s.revoked { "revoked" } else { "" },
            n = escape(&s.name),
        ));
    }
    page(
        "Stores",
        &format!(
            "<h1>Stores</h1><table><tr><th>store</th><th>sessions</th><th>readings</th>\
             <th>events applied</th><th></th></tr>{rows}</table>"
        ),
    )
}

/// `/stores/NAME`: the store's sessions, newest first.
pub fn store_page(station: &str, sessions: &[SessionRow]) -> String {
    let mut rows = String::new();
    for s in sessions {
        rows.push_str(&format!(
            "<tr><td><a href=\"/stores/{st}/sessions/{id}\">{id}</a></td><td>{}</td><td>{}</td>\
             <td>{}</td><td>{}</td><td>{}</td><td class=n>{}</td><td>{}</td></tr>",
            escape(&s.customer),
            time_ms(s.created_at_ms),
            escape(&s.status),
            escape(s.set.as_deref().unwrap_or("-")),
            escape(s.consent.as_deref().unwrap_or("not asked")),
            s.readings,
            if s.has_body { "body" } else { "" },
            st = escape(station),
            id = s.session,
        ));
    }
    page(
        &format!("Store {station}"),
        &format!(
            "<p><a href=\"/\">stores</a></p><h1>Store {}</h1><table><tr><th>session</th>\
             <th>customer</th><th>created (UTC)</th><th>status</th><th>set</th><th>consent</th>\
             <th>readings</th><th></th></tr>{rows}</table>",
            escape(station)
        ),
    )
}

/// The sizes of a stored estimate's report: each reading's target and the
/// body's value, then the set's other measurements taken on the body (mm).
fn sizes_table(report: &serde_json::Value) -> String {
    let mut rows = String::new();
    let mm = |v: &serde_json::Value| {
        v.as_f64()
            .map(|x| format!("{:.1} cm", x / 10.0))
            .unwrap_or_else(|| "-".into())
    };
    if let Some(ms) = report.get("measurements").and_then(|m| m.as_array()) {
        for m in ms {
            rows.push_str(&format!(
                "<tr><td>{}</td><td class=n>{}</td><td class=n>{}</td></tr>",
                escape(m.get("name").and_then(|n| n.as_str()).unwrap_or("?")),
                mm(m.get("target_mm").unwrap_or(&serde_json::Value::Null)),
                mm(m.get("achieved_mm").unwrap_or(&serde_json::Value::Null)),
            ));
        }
    }
    if let Some(ms) = report.get("measured_not_given").and_then(|m| m.as_array()) {
        for m in ms {
            rows.push_str(&format!(
                "<tr><td>{}</td><td class=n>-</td><td class=n>{}</td></tr>",
                escape(m.get(0).and_then(|n| n.as_str()).unwrap_or("?")),
                mm(m.get(1).unwrap_or(&serde_json::Value::Null)),
            ));
        }
    }
    if rows.is_empty() {
        return "<p class=dim>The estimate's report lists no sizes.</p>".into();
    }
    format!(
        "<table id=\"sizes\"><tr><th>measurement</th><th>reading</th><th>on the body</th></tr>{rows}</table>"
    )
}

/// The viewer: three.js draws the GLB at `glb_url` into a canvas; when the
/// body is on screen the page's `data-body` becomes `drawn` and the status
/// line says so (what a browser test can wait for).
fn viewer(glb_url: &str) -> String {
    format!(
        r#"<p id="viewer-status" class="dim">Loading the body...</p>
<canvas id="viewer" width="480" height="640"></canvas>
<script type="importmap">{{"imports":{{"three":"/static/three/three.module.js","three/addons/":"/static/three/addons/"}}}}</script>
<script type="module">
import * as THREE from 'three';
import {{ GLTFLoader }} from 'three/addons/loaders/GLTFLoader.js';
import {{ OrbitControls }} from 'three/addons/controls/OrbitControls.js';
const canvas = document.getElementById('viewer');
const status = document.getElementById('viewer-status');
const renderer = new THREE.WebGLRenderer({{ canvas, antialias: true, preserveDrawingBuffer: true }});
renderer.setClearColor(0xffffff, 1);
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(30, canvas.width / canvas.height, 0.05, 100);
scene.add(new THREE.HemisphereLight(0xffffff, 0x404040, 2.0));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(1, 2, 3);
scene.add(sun);
const controls = new OrbitControls(camera, canvas);
const render = () => renderer.render(scene, camera);
controls.addEventListener('change', render);
// From the origin, not relative to the page: a page opened with
// credentials in its address may not fetch with them.
const glbUrl = new URL('{url}', window.location.origin).href;
new GLTFLoader().load(glbUrl, (gltf) => {{
  const body = gltf.scene;
  // One colour for the body, so that it stands out from the background.
  body.traverse((o) => {{ if (o.isMesh) o.material = new THREE.MeshStandardMaterial({{ color: 0x2f6fd0, roughness: 0.8, side: THREE.DoubleSide }}); }});
  scene.add(body);
  const box = new THREE.Box3().setFromObject(body);
  const centre = box.getCenter(new THREE.Vector3());
  const size = box.getSize(new THREE.Vector3());
  camera.position.set(centre.x, centre.y, centre.z + size.y * 2.2);
  controls.target.copy(centre);
  controls.update();
  render();
  status.textContent = 'Body: drag to turn it, wheel to zoom.';
  document.body.dataset.body = 'drawn';
}}, undefined, (err) => {{
  status.textContent = 'The body could not be loaded: ' + err;
  document.body.dataset.body = 'failed';
}});
</script>"#,
        url = escape(glb_url)
    )
}

/// `/stores/NAME/sessions/ID`: the readings, the estimate's sizes and the body.
pub fn session_page(s: &SessionFull) -> String {
    let mut readings = String::new();
    for r in &s.readings {
        let mut note = Vec::new();
        if let Some(by) = r.superseded_by {
            // In careful mode a reading is superseded by its repeat.
            let word = if s.careful { "repeated" } else { "retaken" };
            note.push(format!("{word} (reading {by})"));
        }
        if r.withdrawn {
            note.push("undone".to_string());
        }
        readings.push_str(&format!(
            "<tr><td>{}</td><td class=n>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(&r.measurement),
            cm(r.value_tenth_mm),
            escape(&r.source),
            time_ms(r.received_at_ms),
            note.join(", ")
        ));
    }
    let marks = if s.marks.is_empty() {
        String::new()
    } else {
        format!(
            "<p>Marks: {}</p>",
            s.marks
                .iter()
                .map(|(m, k)| format!("{} {}", escape(m), escape(k)))
                .collect::<Vec<_>>()
                .join("; ")
        )
    };
    let estimate = match &s.estimate {
        None => {
            "<h2>Body</h2><p class=dim>No estimate was stored for this session.</p>".to_string()
        }
        Some(e) => {
            let body = if e.glb_bytes.is_some() {
                viewer(&format!(
                    "/stores/{}/sessions/{}/body.glb",
                    s.station, s.session
                ))
            } else {
                "<p class=dim>The station sent no body with this estimate.</p>".into()
            };
            format!(
                "<h2>Sizes</h2><p class=dim>Estimated {} ({}).</p>{}<h2>Body</h2>{}",
                time_ms(e.made_at_ms),
                escape(&e.model_source),
                sizes_table(&e.report),
                body
            )
        }
    };
    page(
        &format!("Session {} at {}", s.session, s.station),
        &format!(
            "<p><a href=\"/\">stores</a> / <a href=\"/stores/{st}\">{st}</a></p>\
             <h1>Session {id} at {st}</h1>\
             <p>Customer <b>{}</b>, created {} (UTC), {}, set {}, consent: {}.</p>{}{}\
             <h2>Readings</h2><table id=\"readings\"><tr><th>measurement</th><th>value</th>\
             <th>source</th><th>stored (UTC)</th><th></th></tr>{readings}</table>{marks}{estimate}",
            escape(&s.customer),
            time_ms(s.created_at_ms),
            escape(&s.status),
            escape(s.set.as_deref().unwrap_or("-")),
            escape(s.consent.as_deref().unwrap_or("not asked")),
            s.notes
                .as_deref()
                .map(|n| format!("<p>Notes: {}</p>", escape(n)))
                .unwrap_or_default(),
            if s.careful {
                "<p id=careful>Careful mode: each measurement taken twice (a third time when \
                 the two differed by more than its allowable error), the median kept.</p>"
            } else {
                ""
            },
            st = escape(&s.station),
            id = s.session,
        ),
    )
}

/// The vendored three.js files, by their path under `/static/three/`.
const ASSETS: &[(&str, &[u8])] = &[
    (
        "three.module.js",
        include_bytes!("../assets/three/three.module.js"),
    ),
    (
        "three.core.js",
        include_bytes!("../assets/three/three.core.js"),
    ),
    (
        "addons/loaders/GLTFLoader.js",
        include_bytes!("../assets/three/addons/loaders/GLTFLoader.js"),
    ),
    (
        "addons/utils/BufferGeometryUtils.js",
        include_bytes!("../assets/three/addons/utils/BufferGeometryUtils.js"),
    ),
    (
        "addons/utils/SkeletonUtils.js",
        include_bytes!("../assets/three/addons/utils/SkeletonUtils.js"),
    ),
    (
        "addons/controls/OrbitControls.js",
        include_bytes!("../assets/three/addons/controls/OrbitControls.js"),
    ),
    ("LICENSE", include_bytes!("../assets/three/LICENSE")),
];

/// A vendored file's type and bytes, if `path` names one.
pub fn static_asset(path: &str) -> Option<(&'static str, &'static [u8])> {
    ASSETS.iter().find(|(p, _)| *p == path).map(|(p, b)| {
        let mime = if p.ends_with(".js") {
            "text/javascript; charset=utf-8"
        } else {
            "text/plain; charset=utf-8"
        };
        (mime, *b)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn station_text_cannot_open_a_tag() {
        let e = escape("<script>alert('x')</script> & \"q\"");
        assert_eq!(
            e,
            "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt; &amp; &quot;q&quot;"
        );
        let rows = [SessionRow {
            session: 1,
            customer: "<img src=x onerror=alert(1)>".into(),
            status: "open".into(),
            set: None,
            consent: Some("keep".into()),
            created_at_ms: 0,
            readings: 0,
            has_body: false,
        }];
        let p = store_page("s1", &rows);
        assert!(!p.contains("<img"), "{p}");
        assert!(p.contains("&lt;img src=x"), "{p}");
    }

    #[test]
    fn times_are_utc_dates() {
        assert_eq!(time_ms(0), "1970-01-01 00:00");
        // 2024-02-29 12:34 UTC (a leap day).
        assert_eq!(time_ms(1_709_210_040_000), "2024-02-29 12:34");
        assert_eq!(time_ms(-60_000), "1969-12-31 23:59");
    }

    #[test]
    fn static_assets_are_the_vendored_files() {
        for (path, bytes) in ASSETS {
            let on_disk = std::fs::read(
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("assets/three")
                    .join(path),
            )
            .unwrap();
            assert_eq!(&on_disk, bytes, "{path}");
        }
        assert!(static_asset("three.module.js").is_some());
        assert!(static_asset("../Cargo.toml").is_none());
        assert!(static_asset("/etc/passwd").is_none());
        // What the module imports is served too.
        let module = std::str::from_utf8(static_asset("three.module.js").unwrap().1).unwrap();
        assert!(module.contains("from './three.core.js'"));
        let loader =
            std::str::from_utf8(static_asset("addons/loaders/GLTFLoader.js").unwrap().1).unwrap();
        assert!(loader.contains("'../utils/BufferGeometryUtils.js'"));
        assert!(loader.contains("'../utils/SkeletonUtils.js'"));
    }
}
