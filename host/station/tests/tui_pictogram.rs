//! The measuring screen's guidance: the body pictogram of every
//! measurement of `quick` (one reviewed 80x24 snapshot each, insta), and
//! properties that a wrong picture would break, checked against the
//! template and the measurement definitions directly: each girth drawn at
//! its anchor's height, a height from the floor to its landmark, the chest
//! above the waist above the hip, the right arm on the operator's left,
//! and what is drawn adding up to what the engine measures.

mod tui_fixture;

use std::collections::BTreeSet;

use ratatui::backend::TestBackend;
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::Terminal;
use tapeshape::tui::app::App;
use tapeshape::tui::draw;
use tapeshape::tui::screens::measuring::pictogram::{
    for_set, render, width_for, Pictogram, Placed, SetPictograms, View, HIGHLIGHT,
};
use tapeshape_body::BodyModel;
use tapeshape_measure::{Kind, MeasurementSet};
use tui_fixture::*;

fn render_screen(app: &App) -> String {
    let mut t = Terminal::new(TestBackend::new(80, 24)).unwrap();
    t.draw(|f| draw(app, f)).unwrap();
    t.backend().to_string()
}

/// The quick session of the screen tests with measurement `i` current
/// and the tape reading 83.7 cm.
fn measuring_at(i: usize) -> App {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[]);
    live(&mut a, 8_374);
    let s = a.session.as_mut().unwrap();
    s.current = Some(i);
    s.selected = i;
    a
}

#[test]
fn every_quick_measurement_has_its_pictogram_on_the_measuring_screen() {
    let set = MeasurementSet::builtin("quick").unwrap();
    for (i, def) in set.definitions.iter().enumerate() {
        let screen = render_screen(&measuring_at(i));
        assert!(
            screen.contains(HIGHLIGHT),
            "{}: no highlight on the screen\n{screen}",
            def.name
        );
        insta::assert_snapshot!(format!("pictogram_{}", def.name), screen);
    }
}

#[test]
fn every_terminal_size_draws_and_keeps_the_instruction_and_what_to_do() {
    let set = MeasurementSet::builtin("quick").unwrap();
    for (i, def) in set.definitions.iter().enumerate() {
        let a = measuring_at(i);
        for (w, h) in [
            (1, 1),
            (20, 8),
            (40, 12),
            (60, 20),
            (80, 24),
            (120, 40),
            (300, 120),
        ] {
            let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
            t.draw(|f| draw(&a, f)).unwrap();
            if (w, h) < (80, 24) {
                continue;
            }
            // The screen as one text without its borders and line breaks.
            let text: String = t
                .backend()
                .buffer()
                .content()
                .iter()
                .map(|c| c.symbol())
                .collect::<String>();
            let words = |s: &str| s.split_whitespace().map(str::to_owned).collect::<Vec<_>>();
            // Its first and last words (a clipped instruction loses the
            // last), and the prompt's "button" (the footer has "capture").
            let all = words(&def.description);
            let ends = all.iter().take(3).chain(all.iter().rev().take(2));
            for word in ends {
                assert!(
                    text.contains(word.as_str()),
                    "{} at {w}x{h}: {word:?} of the instruction is missing",
                    def.name
                );
            }
            assert!(
                text.contains("button"),
                "{} at {w}x{h}: what to do is missing",
                def.name
            );
        }
    }
}

fn quick() -> (MeasurementSet, SetPictograms) {
    let set = MeasurementSet::builtin("quick").unwrap();
    let pics = SetPictograms::new(&set, BodyModel::shared().unwrap()).unwrap();
    (set, pics)
}

fn pic<'a>(pics: &'a SetPictograms, name: &str) -> &'a Pictogram {
    pics.measurements[name].as_ref().unwrap()
}

/// A template landmark's position (metres, station frame).
fn landmark(name: &str) -> [f64; 3] {
    let model = BodyModel::shared().unwrap();
    let v = tapeshape_body::anatomy::anatomy().landmarks[name];
    model.template().vertices[v as usize]
}

#[test]
fn what_is_drawn_is_what_the_engine_measures() {
    let (set, pics) = quick();
    let model = BodyModel::shared().unwrap();
    let compiled = set
        .compile(model.topology(), &tapeshape_body::anatomy::anatomy())
        .unwrap();
    let values = compiled.measure(&model.template().vertices).unwrap();
    for (def, measured) in set.definitions.iter().zip(&values) {
        let p = pic(&pics, &def.name);
        let drawn: f64 = p
            .segments
            .iter()
            .map(|[a, b]| (0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>().sqrt())
            .sum();
        assert!(
            (drawn - measured.value).abs() < 1e-9,
            "{}: drawn {drawn} m, measured {} m",
            def.name,
            measured.value
        );
        assert_eq!(p.value, measured.value, "{}", def.name);
    }
}

#[test]
fn girths_are_drawn_at_their_anchor_and_heights_from_the_floor() {
    let (set, pics) = quick();
    let floor = landmark("heel_bottom_left")[2].min(landmark("heel_bottom_right")[2]);
    let mut girths = 0;
    let mut heights = 0;
    for def in &set.definitions {
        let p = pic(&pics, &def.name);
        match &def.kind {
            Kind::Circumference { anchor, normal, .. } if *normal == [0.0, 0.0, 1.0] => {
                girths += 1;
                let z = landmark(anchor)[2];
                for [a, b] in &p.segments {
                    for q in [a, b] {
                        assert!(
                            (q[2] - z).abs() < 1e-6,
                            "{}: a point at z = {:.4} m, the anchor at {z:.4} m",
                            def.name,
                            q[2]
                        );
                    }
                }
                assert!(p.segments.len() >= 3, "{}: not a loop", def.name);
            }
            Kind::Height { landmark: top, .. } => {
                heights += 1;
                let t = landmark(top);
                let [[a, b]] = p.segments[..] else {
                    panic!("{}: {} segments", def.name, p.segments.len());
                };
                assert!((a[2] - floor).abs() < 1e-9, "{}: from {}", def.name, a[2]);
                assert_eq!(b, t, "{}: not up to its landmark", def.name);
                assert!(
                    (a[0] - t[0]).abs() < 1e-12 && (a[1] - t[1]).abs() < 1e-12,
                    "{}: not vertical",
                    def.name
                );
            }
            _ => {}
        }
    }
    // chest, waist, hip, thigh; stature, inside leg.
    assert_eq!((girths, heights), (4, 2));
}

/// The rows and columns of `placed`'s cells that hold the highlight.
fn highlighted(buf: &Buffer, placed: &Placed) -> Vec<(u16, u16)> {
    let a = placed.area;
    let mut out = Vec::new();
    for y in a.top()..a.bottom() {
        for x in a.left()..a.right() {
            if buf[(x, y)].symbol() == HIGHLIGHT {
                out.push((x - a.x, y - a.y));
            }
        }
    }
    out
}

/// The row of a canvas `rows` tall showing height `z` (as the canvas maps
/// a point to a cell: `(top - z) / span * (rows - 1)`).
fn row_of(placed: &Placed, z: f64) -> f64 {
    let [bottom, top] = placed.z_bounds;
    (top - z) / (top - bottom) * f64::from(placed.area.height - 1)
}

fn drawn(pics: &SetPictograms, name: &str, area: Rect) -> (Buffer, Vec<Placed>) {
    let mut buf = Buffer::empty(area);
    let placed = render(pics, pic(pics, name), true, area, &mut buf);
    assert!(!placed.is_empty(), "{name}: nothing drawn in {area:?}");
    (buf, placed)
}

#[test]
fn the_picture_puts_each_measurement_where_the_definition_says() {
    let (set, pics) = quick();
    let area = Rect::new(0, 0, 80, 30);
    let mut girth_rows = std::collections::BTreeMap::new();
    for def in &set.definitions {
        let (buf, placed) = drawn(&pics, &def.name, area);
        assert_eq!(
            placed.len(),
            2,
            "{}: both views fit in 80 columns",
            def.name
        );
        for p in &placed {
            let cells = highlighted(&buf, p);
            assert!(!cells.is_empty(), "{}: nothing highlighted", def.name);
            let rows: BTreeSet<u16> = cells.iter().map(|c| c.1).collect();
            match &def.kind {
                Kind::Circumference { anchor, normal, .. } if *normal == [0.0, 0.0, 1.0] => {
                    // Within a cell of the anchor's height.
                    let want = row_of(p, landmark(anchor)[2]);
                    for r in &rows {
                        assert!(
                            (f64::from(*r) - want).abs() <= 1.0,
                            "{} ({:?}): highlight on row {r}, the anchor on {want:.1}",
                            def.name,
                            p.view
                        );
                    }
                    girth_rows.insert(def.name.clone(), want);
                }
                Kind::Height { landmark: top, .. } => {
                    // One line from the floor's row up to the landmark's.
                    let floor = row_of(p, 0.0);
                    let t = row_of(p, landmark(top)[2]);
                    let (lo, hi) = (*rows.first().unwrap(), *rows.last().unwrap());
                    assert!(
                        (f64::from(lo) - t).abs() <= 1.0,
                        "{}: top {lo} vs {t:.1}",
                        def.name
                    );
                    assert!(
                        (f64::from(hi) - floor).abs() <= 1.0,
                        "{}: bottom {hi} vs {floor:.1}",
                        def.name
                    );
                    assert_eq!(
                        rows.len(),
                        usize::from(hi - lo + 1),
                        "{}: the line has gaps",
                        def.name
                    );
                    let cols: BTreeSet<u16> = cells.iter().map(|c| c.0).collect();
                    assert!(cols.len() <= 2, "{}: not vertical: {cols:?}", def.name);
                }
                _ => {}
            }
        }
    }
    // The chest above the waist above the hip.
    assert!(girth_rows["chest"] < girth_rows["waist"], "{girth_rows:?}");
    assert!(girth_rows["waist"] < girth_rows["hip"], "{girth_rows:?}");
}

#[test]
fn the_right_arm_is_on_the_operators_left_and_the_neck_tilts_in_the_side_view() {
    let (_, pics) = quick();
    let area = Rect::new(0, 0, 80, 30);
    for name in ["arm_length", "upper_arm", "thigh"] {
        let (buf, placed) = drawn(&pics, name, area);
        let front = placed.iter().find(|p| p.view == View::Front).unwrap();
        // The centre column holds the midline (the inner thigh reaches it
        // at the crotch); nothing is right of it, and most is left.
        let middle = front.area.width / 2;
        let cells = highlighted(&buf, front);
        for (x, _) in &cells {
            assert!(
                *x <= middle,
                "{name}: highlight in column {x} of {}",
                front.area.width
            );
        }
        let left = cells.iter().filter(|(x, _)| *x < middle).count();
        assert!(2 * left > cells.len(), "{name}: {cells:?}");
    }
    // The neck's plane rises from the breastbone to the back of the neck,
    // by about 3 cm: from the side (front on the right) its back, on the
    // left, is higher. Drawn 160 rows tall (about 1.1 cm a row) so that
    // the tilt spans rows.
    let neck = pic(&pics, "neck").projected(View::Side);
    let ends = neck.iter().flatten();
    let back = ends.clone().min_by(|a, b| a.0.total_cmp(&b.0)).unwrap();
    let front = ends.max_by(|a, b| a.0.total_cmp(&b.0)).unwrap();
    assert!(
        back.1 > front.1 + 0.02,
        "neck: back {back:?}, front {front:?}"
    );
    let rows = 160;
    let cols = width_for(&pics, pic(&pics, "neck"), rows, true);
    let (buf, placed) = drawn(&pics, "neck", Rect::new(0, 0, cols, rows));
    let side = placed.iter().find(|p| p.view == View::Side).unwrap();
    let cells = highlighted(&buf, side);
    let left = cells.iter().min_by_key(|c| c.0).unwrap();
    let right = cells.iter().max_by_key(|c| c.0).unwrap();
    assert!(left.1 + 2 <= right.1, "neck from the side: {cells:?}");
}

#[test]
fn a_girth_is_seen_edge_on_and_a_line_where_it_is_longest() {
    let (set, pics) = quick();
    for def in &set.definitions {
        let p = pic(&pics, &def.name);
        let want = match &def.kind {
            // The view direction closer to the girth's plane: y (front)
            // when the normal has less of y than of x.
            Kind::Circumference { normal, .. } if normal[1].abs() > normal[0].abs() => View::Side,
            // The neck base loop (the only loop of `quick`) rises from the
            // jugular notch to C7 (ISO 8559-1): from the side it is seen
            // edge on, a tilted line.
            Kind::GeodesicLoop { .. } => View::Side,
            _ => View::Front,
        };
        assert_eq!(p.view, want, "{}", def.name);
    }
    assert_eq!(pic(&pics, "neck").view, View::Side);
    assert_eq!(pic(&pics, "upper_arm").view, View::Front);
}

#[test]
fn small_areas_draw_one_view_or_none_and_the_cache_keeps_one_set() {
    let (_, pics) = quick();
    for name in ["chest", "neck"] {
        let p = pic(&pics, name);
        // Too few rows: nothing.
        let mut buf = Buffer::empty(Rect::new(0, 0, 40, 5));
        assert!(render(&pics, p, true, buf.area, &mut buf).is_empty());
        assert!(buf.content().iter().all(|c| c.symbol() == " "));
        // Room for one view: the one the measurement is better seen in.
        let one = width_for(&pics, p, 12, false);
        let both = width_for(&pics, p, 12, true);
        assert!(one < both, "{name}: {one} / {both}");
        let mut buf = Buffer::empty(Rect::new(0, 0, both - 1, 12));
        let placed = render(&pics, p, true, buf.area, &mut buf);
        assert_eq!(placed.len(), 1, "{name}");
        assert_eq!(placed[0].view, p.view, "{name}");
        let mut buf = Buffer::empty(Rect::new(0, 0, both, 12));
        assert_eq!(
            render(&pics, p, true, buf.area, &mut buf).len(),
            2,
            "{name}"
        );
        let mut buf = Buffer::empty(Rect::new(0, 0, one - 1, 12));
        assert!(
            render(&pics, p, true, buf.area, &mut buf).is_empty(),
            "{name}"
        );
    }
    let a = for_set("quick");
    let b = for_set("quick");
    assert!(std::sync::Arc::ptr_eq(&a, &b));
    assert_eq!(a.as_ref().as_ref().unwrap(), &pics);
    assert!(for_set("no-such-set").is_err());
}
