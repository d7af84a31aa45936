//! The customer's card, turned back into text and pixels with poppler
//! (`pdftotext`, `pdftoppm`): `tapeshape predict --card` with a chart, and
//! `tapeshape session show ID --card` of a stored session. Every number
//! checked comes from the `--report` JSON of the same run (or the store),
//! none is written here.
//!
//! Without poppler these tests skip with a message, unless `CI` is set
//! (`.ci/run` installs poppler-utils): then they fail.

mod common;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

/// Whether `pdftotext` and `pdftoppm` run; else skip (or fail in CI).
fn poppler_or_skip(test: &str) -> bool {
    let runs = |tool: &str| {
        Command::new(tool)
            .arg("-v")
            .output()
            .map(|o| o.status.success())
            .unwrap_or(false)
    };
    if runs("pdftotext") && runs("pdftoppm") {
        return true;
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "{test}: pdftotext or pdftoppm is missing, and CI is set: CI must install them \
         (apt-get install -y poppler-utils)"
    );
    eprintln!(
        "\n*** SKIPPED {test}: pdftotext or pdftoppm is missing (apt-get install -y poppler-utils) ***\n"
    );
    false
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn run(data: &Path, args: &[&str]) -> String {
    let out = common::tapeshape(data, args).output().unwrap();
    assert!(
        out.status.success(),
        "tapeshape {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// The card's text, laid out as on the page (one line per line).
fn text_of(pdf: &Path) -> String {
    let out = Command::new("pdftotext")
        .args(["-layout", "-enc", "UTF-8"])
        .arg(pdf)
        .arg("-")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// One page rasterised by `pdftoppm` (PPM, `dpi` dots per inch): width,
/// height, RGB samples.
struct Raster {
    w: usize,
    h: usize,
    rgb: Vec<u8>,
}

impl Raster {
    fn px(&self, x: usize, y: usize) -> [u8; 3] {
        let i = 3 * (y * self.w + x);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }
}

/// Rasterises every page of `pdf` at `dpi`.
fn pages_of(pdf: &Path, dpi: u32, dir: &Path) -> Vec<Raster> {
    let prefix = dir.join("page");
    let out = Command::new("pdftoppm")
        .args(["-r", &dpi.to_string()])
        .arg(pdf)
        .arg(&prefix)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ppm"))
        .collect();
    files.sort();
    files.iter().map(|f| read_ppm(f)).collect()
}

/// A binary PPM (P6, 8 bit): what `pdftoppm` writes by default.
fn read_ppm(path: &Path) -> Raster {
    let bytes = std::fs::read(path).unwrap();
    // Header: "P6", width, height, maxval, each after white space, then
    // one white-space byte and the samples.
    let mut fields = Vec::new();
    let mut i = 0;
    while fields.len() < 4 {
        while bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        let start = i;
        while !bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        fields.push(String::from_utf8_lossy(&bytes[start..i]).into_owned());
    }
    assert_eq!(fields[0], "P6");
    assert_eq!(fields[3], "255");
    let (w, h) = (fields[1].parse().unwrap(), fields[2].parse().unwrap());
    let rgb = bytes[i + 1..].to_vec();
    assert_eq!(rgb.len(), w * h * 3);
    Raster { w, h, rgb }
}

/// The body's pixels: the renders' warm tone (red well above blue); the
/// card's text and rules are grey.
fn is_body([r, _, b]: [u8; 3]) -> bool {
    i32::from(r) - i32::from(b) > 15 && r > 40
}

/// A figure's box on the page, pixels (x0..x1, y0..y1 exclusive).
#[derive(Debug, Clone, Copy)]
struct Figure {
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
}

impl Figure {
    fn width(&self) -> usize {
        self.x1 - self.x0
    }
    fn height(&self) -> usize {
        self.y1 - self.y0
    }
    /// How many body pixels the figure has on row `y`.
    fn row_width(&self, page: &Raster, y: usize) -> usize {
        (self.x0..self.x1)
            .filter(|&x| is_body(page.px(x, y)))
            .count()
    }
}

/// The figures on `page`: runs of columns holding body pixels, split by
/// empty columns.
fn figures(page: &Raster) -> Vec<Figure> {
    let column: Vec<Option<(usize, usize)>> = (0..page.w)
        .map(|x| {
            let ys: Vec<usize> = (0..page.h).filter(|&y| is_body(page.px(x, y))).collect();
            Some((*ys.first()?, *ys.last()? + 1))
        })
        .collect();
    let mut out: Vec<Figure> = Vec::new();
    let mut x = 0;
    while x < page.w {
        if column[x].is_none() {
            x += 1;
            continue;
        }
        let mut f = Figure {
            x0: x,
            x1: x,
            y0: usize::MAX,
            y1: 0,
        };
        while x < page.w {
            let Some((a, b)) = column[x] else { break };
            f.y0 = f.y0.min(a);
            f.y1 = f.y1.max(b);
            x += 1;
        }
        f.x1 = x;
        out.push(f);
    }
    out
}

/// The page's front and side figures, checked for what a body drawn front
/// and side looks like.
fn check_figures(page: &Raster) {
    let figs = figures(page);
    assert_eq!(figs.len(), 2, "two figures, front and side: {figs:?}");
    let (front, side) = (figs[0], figs[1]);
    // In the left column, below the header, under one another's scale.
    assert!(side.x1 < page.w / 2, "{figs:?}");
    assert!(front.y0 > page.h / 10, "below the header: {figs:?}");
    assert!(front.height() > page.h / 4, "a large figure: {figs:?}");
    assert!(
        front.height().abs_diff(side.height()) <= 2,
        "one scale: {figs:?}"
    );
    assert!(front.height() > front.width(), "{figs:?}");
    assert!(side.height() > 2 * side.width(), "{figs:?}");
    // A person: at the shoulders (a fifth down from the top) the front is
    // wider than the side; at the top (the head) both are narrow.
    let shoulders = front.y0 + front.height() / 5;
    let (fw, sw) = (
        front.row_width(page, shoulders),
        side.row_width(page, shoulders),
    );
    assert!(fw > sw, "front {fw} px, side {sw} px at the shoulders");
    let head = front.y0 + front.height() / 20;
    assert!(
        front.row_width(page, head) < fw / 2,
        "the head narrower than the shoulders"
    );
    // Shaded, not flat: the body spans light and dark tones.
    let tones: Vec<u8> = (front.y0..front.y1)
        .flat_map(|y| (front.x0..front.x1).map(move |x| (x, y)))
        .map(|(x, y)| page.px(x, y))
        .filter(|p| is_body(*p))
        .map(|p| p[0])
        .collect();
    let (lo, hi) = (
        tones.iter().min().copied().unwrap(),
        tones.iter().max().copied().unwrap(),
    );
    assert!(hi - lo > 60, "shading from {lo} to {hi}");
}

/// Lengths as the card prints them in centimetres.
fn cm(mm: f64) -> String {
    format!("{:.1} cm", mm / 10.0)
}

/// A probability as the card prints it (tapeshape_sizes::text::percent).
fn percent(p: f64) -> String {
    if p > 0.0 && p < 0.005 {
        "<1 %".to_string()
    } else if (0.995..1.0).contains(&p) {
        ">99 %".to_string()
    } else {
        format!("{:.0} %", 100.0 * p)
    }
}

/// The model's labels by measurement name, from `predict --list`.
fn labels(data: &Path) -> HashMap<String, String> {
    run(data, &["predict", "--list"])
        .lines()
        .skip(1)
        .filter_map(|l| {
            let mut parts = l.split_whitespace();
            let name = parts.next()?.to_string();
            let _sets = parts.next()?;
            Some((name, parts.collect::<Vec<_>>().join(" ")))
        })
        .collect()
}

/// The line of `text` that holds all of `parts`, in order.
fn line_with<'a>(text: &'a str, parts: &[&str]) -> Option<&'a str> {
    text.lines().find(|l| {
        let mut at = 0;
        parts.iter().all(|p| match l[at..].find(p) {
            Some(i) => {
                at += i + p.len();
                true
            }
            None => false,
        })
    })
}

/// `2026-05-02 14:03 UTC` of the minute `ms` falls in.
fn minute(ms: i64) -> String {
    let t = humantime::format_rfc3339_seconds(
        std::time::UNIX_EPOCH + std::time::Duration::from_millis(ms as u64),
    )
    .to_string();
    format!("{} {} UTC", &t[..10], &t[11..16])
}

fn now_ms() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_millis() as i64
}

#[test]
fn predict_writes_a_card_with_the_readings_the_body_and_the_sizes() {
    if !poppler_or_skip("predict_writes_a_card_with_the_readings_the_body_and_the_sizes") {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let (card, report) = (tmp.path().join("card.pdf"), tmp.path().join("report.json"));
    let chart = repo().join("examples/size-charts/menswear.toml");
    let before = now_ms();
    let out = run(
        tmp.path(),
        &[
            "predict",
            "--measure",
            "stature=176.5cm",
            "--measure",
            "chest=98cm",
            "--measure",
            "waist=84cm",
            "--measure",
            "hip=99cm",
            "--chart",
            chart.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
            "--card",
            card.to_str().unwrap(),
        ],
    );
    let after = now_ms();
    assert!(out.contains(&format!("card: {}", card.display())), "{out}");
    let r: Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let labels = labels(tmp.path());
    let text = text_of(&card);

    // The readings taken, each with its label and the value given.
    let inputs = r["inputs"].as_array().unwrap();
    assert_eq!(inputs.len(), 4);
    for c in inputs {
        let name = c["name"].as_str().unwrap();
        let value = cm(c["value_mm"].as_f64().unwrap());
        let line = line_with(&text, &[&labels[name], &value]);
        let line = line.unwrap_or_else(|| panic!("{name} {value} not on the card:\n{text}"));
        assert!(!line.contains("from the body"), "{line}");
    }
    // The rest of the quick set, read off the body and marked so, with the
    // value the body has; the sizes' spread for the dimensions they used.
    let spreads: HashMap<&str, f64> = r["sizes"]["garments"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|g| g["readings"].as_array().unwrap())
        .filter(|u| u["source"] == "estimated")
        .map(|u| {
            (
                u["dimension"].as_str().unwrap(),
                u["sd_mm"].as_f64().unwrap(),
            )
        })
        .collect();
    assert!(spreads.contains_key("neck") && spreads.contains_key("inside_leg"));
    let measured = r["prediction"]["measurements"].as_array().unwrap();
    for name in ["neck", "inside_leg", "arm_length", "thigh", "upper_arm"] {
        let m = measured.iter().find(|m| m["name"] == name).unwrap();
        let value = cm(m["step2_mm"].as_f64().unwrap());
        let mut parts = vec![labels[name].as_str(), "from the body", value.as_str()];
        let spread = spreads.get(name).map(|sd| format!("± {}", cm(*sd)));
        if let Some(s) = &spread {
            parts.push(s);
        }
        assert!(
            line_with(&text, &parts).is_some(),
            "{parts:?} not on the card:\n{text}"
        );
    }
    let marked = text.matches("from the body").count();
    assert!(marked >= 5, "{marked} marks");
    // The size per garment with its probability.
    for g in r["sizes"]["garments"].as_array().unwrap() {
        let best = &g["best"];
        let head = format!(
            "{}: {} ({})",
            g["garment"].as_str().unwrap(),
            best["label"].as_str().unwrap(),
            percent(best["probability"].as_f64().unwrap())
        );
        assert!(line_with(&text, &[&head]).is_some(), "{head}:\n{text}");
    }
    assert!(text.contains("Sizes"));
    // No session, the date of the run, the units and the frame.
    assert!(
        line_with(&text, &["Session: no session"]).is_some(),
        "{text}"
    );
    let dated = [minute(before), minute(after)]
        .iter()
        .any(|d| text.contains(&format!("Date: {d}")));
    assert!(dated, "no date between {before} and {after}:\n{text}");
    assert!(text.contains("Lengths in centimetres (cm)"));
    let flat = text.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        flat.contains("station's frame (Z up, +Y the body's front, +X the body's right; metres)"),
        "{flat}"
    );
    // Nothing of a customer: predict has none, and the card says no more
    // than it was given.
    assert!(!text.to_lowercase().contains("customer"), "{text}");
    assert!(!text.contains("Name"), "{text}");

    // The page: one, with the body front and side.
    let pages = pages_of(&card, 50, tmp.path());
    assert_eq!(pages.len(), 1);
    check_figures(&pages[0]);
}

#[test]
fn a_stored_session_card_has_its_id_and_date_and_nothing_of_the_customer() {
    if !poppler_or_skip("a_stored_session_card_has_its_id_and_date_and_nothing_of_the_customer") {
        return;
    }
    use tapeshape::session::Sessions;

    let data = tempfile::tempdir().unwrap();
    let readings: [(&str, u32); 5] = [
        ("stature", 16_980),
        ("chest", 10_120),
        ("waist", 8_890),
        ("hip", 10_050),
        ("inside_leg", 7_810),
    ];
    let (id, made_at) = {
        let sessions = Sessions::open(data.path()).unwrap();
        let view = sessions
            .start("Jane-Doe-4711", "quick", Some("prefers blue shirts"))
            .unwrap();
        for (name, v) in readings {
            sessions.capture_keyboard(view.id, name, v).unwrap();
        }
        let readings: Vec<(String, u32)> =
            readings.iter().map(|(n, v)| (n.to_string(), *v)).collect();
        common::estimate_and_wait(&sessions, view.id, &readings);
        let stored = sessions.store().estimate(view.id).unwrap().unwrap();
        (view.id, stored.made_at_ms)
    };
    let card = data.path().join("out").join("card.pdf");
    let chart = repo().join("examples/size-charts/menswear.toml");
    let out = run(
        data.path(),
        &[
            "session",
            "show",
            &id.0.to_string(),
            "--chart",
            chart.to_str().unwrap(),
            "--card",
            card.to_str().unwrap(),
        ],
    );
    assert!(out.contains("card: "), "{out}");
    let text = text_of(&card);
    assert!(
        line_with(&text, &[&format!("Session: {}", id.0)]).is_some(),
        "{text}"
    );
    assert!(
        text.contains(&format!("Date: {}", minute(made_at))),
        "{}:\n{text}",
        minute(made_at)
    );
    for (name, v) in readings {
        assert!(
            text.contains(&cm(f64::from(v) / 10.0)),
            "{name} {v}:\n{text}"
        );
    }
    // The session's customer id and notes were never given to the card.
    for word in ["Jane", "Doe", "4711", "blue", "prefers", "customer"] {
        assert!(!text.contains(word), "{word} on the card:\n{text}");
    }
    assert!(text.contains("trousers: "), "{text}");
    let pages = pages_of(&card, 50, data.path());
    check_figures(&pages[0]);
}
