//! The measuring screen's body pictogram: the template's silhouette with
//! the current measurement's path, girth or line highlighted.
//!
//! Why from the engine: the highlighted lines are the support the
//! measurement engine itself returns when it measures the template
//! ([`tapeshape_measure::CompiledSet::measure_one`]), taken as the engine
//! measures it ([`tapeshape_measure::Support::measured_segments`]: a height
//! is the vertical from the floor's level to its landmark, a girth the hull
//! of its plane cut). So the picture cannot show a girth at another level
//! or a path between other points than the ones the estimate fits; their
//! lengths add up to the template's value.
//!
//! Computed once per measurement set (template + set -> per-measurement 3D
//! segments, station frame, metres; see [`for_set`]), not per frame, and
//! drawn on a braille [`Canvas`] like the result screen's silhouettes. The
//! highlight is drawn on a layer of its own with full blocks (`█`), so it
//! stands out from the braille body in monochrome as well as in colour.

use std::collections::BTreeMap;
use std::sync::{Arc, LazyLock, Mutex};

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Color;
use ratatui::symbols::Marker;
use ratatui::widgets::canvas::{Canvas, Line as CanvasLine, Points};
use ratatui::widgets::Widget;
use tapeshape_body::BodyModel;
use tapeshape_measure::{MeasureError, MeasurementSet};
use tapeshape_mesh::Vec3;

use crate::services::station::silhouettes;
use crate::services::Silhouettes;

/// Which way the pictogram looks at the body.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// From the front, as the operator facing the customer sees them:
    /// (-x, z), the customer's right on the left.
    Front,
    /// From the body's right side: (y, z), the front on the right.
    Side,
}

impl View {
    /// A station-frame point (metres) in this view's plane (metres).
    pub fn project(self, p: Vec3) -> (f64, f64) {
        match self {
            View::Front => (-p[0], p[2]),
            View::Side => (p[1], p[2]),
        }
    }
}

/// One measurement drawn on the template.
#[derive(Clone, Debug, PartialEq)]
pub struct Pictogram {
    /// The segments the engine measures on the template, station frame,
    /// metres (see the module docs); their lengths add up to `value`.
    pub segments: Vec<[Vec3; 2]>,
    /// The template's value of the measurement, metres.
    pub value: f64,
    /// The view it is better seen in: the side for a girth whose plane
    /// tilts front to back (the neck) and for a line seen longer from the
    /// side (a depth), else the front (see [`Pictogram::better_view`]).
    pub view: View,
}

impl Pictogram {
    /// The segments projected into `view` (metres).
    pub fn projected(&self, view: View) -> Vec<[(f64, f64); 2]> {
        self.segments
            .iter()
            .map(|[a, b]| [view.project(*a), view.project(*b)])
            .collect()
    }

    /// The view the measurement is better seen in. A loop (a girth) is
    /// clearest seen edge-on, as a line across the body or limb: the view
    /// whose direction lies closer to the loop's plane (its area vector,
    /// Newell's sum, points less along the view direction: y from the
    /// front, x from the side). An open path or line is clearest where it
    /// is foreshortened least: the view that sees it longer. Ties go to
    /// the front (a horizontal girth, a height).
    pub fn better_view(&self) -> View {
        let closed = match (self.segments.first(), self.segments.last()) {
            (Some(first), Some(last)) => self.segments.len() >= 3 && first[0] == last[1],
            _ => false,
        };
        let area = if closed {
            let mut a = [0.0; 3];
            for [p, q] in &self.segments {
                a[0] += (p[1] - q[1]) * (p[2] + q[2]);
                a[1] += (p[2] - q[2]) * (p[0] + q[0]);
                a[2] += (p[0] - q[0]) * (p[1] + q[1]);
            }
            Some(a).filter(|a| a.iter().any(|c| *c != 0.0))
        } else {
            None
        };
        let side_better = match area {
            Some(a) => a[1].abs() > a[0].abs(),
            None => self.seen_length(View::Side) > self.seen_length(View::Front),
        };
        if side_better {
            View::Side
        } else {
            View::Front
        }
    }

    /// Total length of the segments seen in `view` (metres).
    fn seen_length(&self, view: View) -> f64 {
        self.projected(view)
            .iter()
            .map(|[a, b]| (b.0 - a.0).hypot(b.1 - a.1))
            .sum()
    }
}

/// The pictograms of one measurement set on the template.
#[derive(Clone, Debug, PartialEq)]
pub struct SetPictograms {
    /// The template's outlines (points, metres) as [`View::project`] sees
    /// them: `front` is (-x, z), `side` (y, z).
    pub silhouettes: Silhouettes,
    /// Per measurement name: its pictogram, or why the engine could not
    /// measure it on the template (a set file's plane that misses it).
    pub measurements: BTreeMap<String, Result<Pictogram, String>>,
}

/// Why no pictograms could be made for a set.
#[derive(Debug, thiserror::Error)]
pub enum PictogramError {
    /// The set could not be loaded or compiled against the template.
    #[error("measurement set {set:?}: {source}")]
    Set {
        /// The set's name or file.
        set: String,
        /// Why.
        #[source]
        source: Box<MeasureError>,
    },
    /// The body template could not be loaded.
    #[error("the body template: {0}")]
    Body(#[from] tapeshape_body::BodyError),
}

impl SetPictograms {
    /// Measures every measurement of `set` on the template of `model` and
    /// keeps what the engine measured (see the module docs).
    pub fn new(set: &MeasurementSet, model: &BodyModel) -> Result<Self, PictogramError> {
        let anatomy = tapeshape_body::anatomy::anatomy();
        let compiled =
            set.compile(model.topology(), &anatomy)
                .map_err(|source| PictogramError::Set {
                    set: set.name.clone(),
                    source: Box::new(source),
                })?;
        let template = model.template();
        let p = &template.vertices;
        let measurements = set
            .definitions
            .iter()
            .enumerate()
            .map(|(i, def)| {
                let pic = compiled
                    .measure_one(i, p)
                    .map(|m| {
                        let mut pic = Pictogram {
                            segments: m.support.measured_segments(p),
                            value: m.value,
                            view: View::Front,
                        };
                        pic.view = pic.better_view();
                        pic
                    })
                    .map_err(|e| e.to_string());
                (def.name.clone(), pic)
            })
            .collect();
        // The station's outlines with x turned, as [`View::Front`] looks.
        let facing: Vec<Vec3> = p.iter().map(|v| [-v[0], v[1], v[2]]).collect();
        Ok(Self {
            silhouettes: silhouettes(&facing),
            measurements,
        })
    }
}

/// A set's pictograms as [`for_set`] keeps them, or why there are none.
pub type Made = Arc<Result<SetPictograms, String>>;

/// The pictograms of the set `set` (a built-in name or a set file, as a
/// session names it) on the shared body template, made on first use and
/// kept for the process; a frame only draws them. Measured in a debug test
/// build: 25 ms for `quick`, 30 ms for `ansur`, after the shared body
/// model's load (0.5 s, once per process; the runner makes the default
/// set's on a thread at start). An error is kept too, as its message.
pub fn for_set(set: &str) -> Made {
    static CACHE: LazyLock<Mutex<BTreeMap<String, Made>>> = LazyLock::new(Mutex::default);
    // A panic elsewhere while the lock was held leaves plain data behind.
    let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    cache
        .entry(set.to_string())
        .or_insert_with(|| {
            let made = MeasurementSet::load(set)
                .map_err(|source| PictogramError::Set {
                    set: set.to_string(),
                    source: Box::new(source),
                })
                .and_then(|s| SetPictograms::new(&s, BodyModel::shared()?));
            Arc::new(made.map_err(|e| e.to_string()))
        })
        .clone()
}

/// Where a view was drawn: its cells and the canvas bounds (metres) they
/// show, so that tests can map heights to rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placed {
    /// The view.
    pub view: View,
    /// Its cells.
    pub area: Rect,
    /// Horizontal bounds, metres (-x from the front, y from the side).
    pub x_bounds: [f64; 2],
    /// Vertical bounds (z), metres.
    pub z_bounds: [f64; 2],
}

/// The symbol the highlight is drawn with (a full block: visible beside
/// braille dots without colour).
pub const HIGHLIGHT: &str = "█";

/// Fewest rows a pictogram is drawn in (below that a body is a smudge).
pub const MIN_ROWS: u16 = 6;

/// Columns the views of `pic` need at `rows` rows, both views when `both`
/// (one blank column between them), else its preferred view only.
pub fn width_for(set: &SetPictograms, pic: &Pictogram, rows: u16, both: bool) -> u16 {
    let scale = Scale::new(set, pic, rows);
    if both {
        scale
            .cols(View::Front)
            .saturating_add(1)
            .saturating_add(scale.cols(View::Side))
    } else {
        scale.cols(pic.view)
    }
}

/// The shared scale of a pictogram's views: one metre per dot for both,
/// so that front and side are the same height.
struct Scale {
    z: [f64; 2],
    per_dot: f64,
    front: [f64; 2],
    side: [f64; 2],
}

impl Scale {
    fn new(set: &SetPictograms, pic: &Pictogram, rows: u16) -> Self {
        fn range(points: impl Iterator<Item = (f64, f64)>) -> ([f64; 2], [f64; 2]) {
            let mut h = [f64::INFINITY, f64::NEG_INFINITY];
            let mut v = [f64::INFINITY, f64::NEG_INFINITY];
            for (a, b) in points.filter(|(a, b)| a.is_finite() && b.is_finite()) {
                h = [h[0].min(a), h[1].max(a)];
                v = [v[0].min(b), v[1].max(b)];
            }
            if h[0] > h[1] {
                ([-0.5, 0.5], [0.0, 1.0])
            } else {
                (h, v)
            }
        }
        let ends = |view: View| {
            pic.projected(view)
                .into_iter()
                .flatten()
                .collect::<Vec<_>>()
        };
        let (front, zf) = range(
            set.silhouettes
                .front
                .iter()
                .copied()
                .chain(ends(View::Front)),
        );
        let (side, zs) = range(set.silhouettes.side.iter().copied().chain(ends(View::Side)));
        let z = [zf[0].min(zs[0]), zf[1].max(zs[1])];
        // A margin of 2 % so the head and the soles stay inside.
        let span = (z[1] - z[0]).max(1e-3) * 1.02;
        let per_dot = span / (f64::from(rows.max(1)) * 4.0);
        let mid = (z[0] + z[1]) / 2.0;
        Self {
            z: [mid - span / 2.0, mid + span / 2.0],
            per_dot,
            front,
            side,
        }
    }

    /// Columns a view needs: two braille dots a column, square dots.
    fn cols(&self, view: View) -> u16 {
        let [lo, hi] = self.range(view);
        let dots = ((hi - lo) / self.per_dot).ceil() + 2.0;
        (dots / 2.0).ceil().clamp(1.0, f64::from(u16::MAX)) as u16
    }

    fn range(&self, view: View) -> [f64; 2] {
        match view {
            View::Front => self.front,
            View::Side => self.side,
        }
    }

    /// The bounds of `view` centred in `cols` columns.
    fn x_bounds(&self, view: View, cols: u16) -> [f64; 2] {
        let [lo, hi] = self.range(view);
        let half = self.per_dot * f64::from(cols);
        let c = (lo + hi) / 2.0;
        [c - half, c + half]
    }
}

/// Draws `pic` on the template into `area` of `buf`: both views side by
/// side when they fit, else the view it is better seen in. Returns what was
/// drawn where (nothing when `area` has fewer than [`MIN_ROWS`] rows or
/// not even one view fits).
pub fn render(
    set: &SetPictograms,
    pic: &Pictogram,
    mono: bool,
    area: Rect,
    buf: &mut Buffer,
) -> Vec<Placed> {
    if area.height < MIN_ROWS {
        return Vec::new();
    }
    let scale = Scale::new(set, pic, area.height);
    let (front, side) = (scale.cols(View::Front), scale.cols(View::Side));
    let views: Vec<(View, u16)> = if front.saturating_add(1).saturating_add(side) <= area.width {
        vec![(View::Front, front), (View::Side, side)]
    } else if scale.cols(pic.view) <= area.width {
        vec![(pic.view, scale.cols(pic.view))]
    } else {
        return Vec::new();
    };
    // At most `area.width`: checked above.
    let used: u16 = views.iter().map(|(_, w)| w).sum::<u16>() + (views.len() as u16 - 1);
    let mut x = area.x + (area.width - used) / 2;
    let mut placed = Vec::new();
    for (view, cols) in views {
        let cell = Rect::new(x, area.y, cols, area.height);
        x = x.saturating_add(cols).saturating_add(1);
        let p = Placed {
            view,
            area: cell,
            x_bounds: scale.x_bounds(view, cols),
            z_bounds: scale.z,
        };
        draw_view(set, pic, mono, &p, buf);
        placed.push(p);
    }
    placed
}

fn draw_view(set: &SetPictograms, pic: &Pictogram, mono: bool, p: &Placed, buf: &mut Buffer) {
    let body: &[(f64, f64)] = match p.view {
        View::Front => &set.silhouettes.front,
        View::Side => &set.silhouettes.side,
    };
    let lines = pic.projected(p.view);
    let (body_color, mark_color) = if mono {
        (Color::Reset, Color::Reset)
    } else {
        (Color::DarkGray, Color::Yellow)
    };
    Canvas::default()
        .marker(Marker::Braille)
        .x_bounds(p.x_bounds)
        .y_bounds(p.z_bounds)
        .paint(move |ctx| {
            ctx.draw(&Points {
                coords: body,
                color: body_color,
            });
            // The highlight on its own layer, one full block a cell: it
            // covers the braille body where it runs.
            ctx.marker(Marker::Block);
            for [a, b] in &lines {
                ctx.draw(&CanvasLine {
                    x1: a.0,
                    y1: a.1,
                    x2: b.0,
                    y2: b.1,
                    color: mark_color,
                });
            }
        })
        .render(p.area, buf);
}
