//! The customer's card (issue 14): a one- or two-page A4 PDF the customer
//! takes away from the fitting room. It shows the estimated body front and
//! side (shaded renders), the measurements the operator took, the
//! dimensions read off the body (marked "from the body", with their
//! spread), the size per garment when the station has a chart, the session
//! id (or "no session"), the date, and the units and frame of what it
//! shows.
//!
//! What it leaves out on purpose: the customer's id and name, the session's
//! notes, the consent, anything the customer did not give. A [`Card`]
//! carries no field for them, so no caller can put them on the card.
//!
//! Why `pdf-writer` (typst's low-level PDF writer, MIT OR Apache-2.0):
//! it is small and well kept, writes exactly the objects asked for, and
//! brings no crate the tree lacks (its dependencies bitflags 2, itoa, memchr
//! and ryu were already in it; `cargo deny check` stays clean). The larger
//! PDF crates (printpdf, lopdf) pull in font parsers and a second copy of
//! several crates. The card needs no embedded font: it uses the base-14
//! Helvetica family every PDF reader has, with WinAnsi text ([`win_ansi`]).
//! The renders are the station's own software renderer
//! (`tapeshape_body::render`), embedded as RGB images deflated with
//! `flate2` (already in the tree). The page text streams are left
//! uncompressed: they are a few kilobytes, and a reader (or a test) can see
//! the text in the file.
//!
//! Layout is written by hand (A4 in PDF points, origin bottom left): base-14
//! fonts come with no layout engine, so text widths for right-aligned
//! numbers and line wrapping come from Helvetica's published glyph widths
//! ([`text_width`]).
//!
//! Units: every length in the [`Card`] is millimetres; the card prints them
//! in the card's [`Unit`] (centimetres by default). The body is in the
//! station frame (metres, Z up, +Y the body's front, +X the body's right);
//! the front view looks along -Y, the side view along -X, both at one scale.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use pdf_writer::{Content, Filter, Finish as _, Name, Pdf, Rect, Ref, Str, TextStr};
use tapeshape_body::render::{render_panel, Colouring, Panel, RenderError, View};
use tapeshape_estimator::{EstimateReport, Estimator, Unit};
use tapeshape_mesh::{Mesh, Vec3};
use tapeshape_sizes::{BetweenReason, GarmentFit, Recommendation, Role, Side, SizeFit, Source};

use crate::text::format_length_mm;

/// One dimension on the card (millimetres).
#[derive(Debug, Clone, PartialEq)]
pub struct CardValue {
    /// The station's measurement name (`chest`).
    pub name: String,
    /// Its label as the customer reads it (`Chest / bust`).
    pub label: String,
    /// The value, mm.
    pub value_mm: f64,
    /// One standard deviation, mm, of a value read off the body (`None`
    /// for a reading taken, or where the estimate has no spread for it).
    pub sd_mm: Option<f64>,
}

/// What the card shows, and nothing else (see the module docs).
#[derive(Debug, Clone)]
pub struct Card {
    /// The station's session id; `None` for `tapeshape predict` ("no session").
    pub session: Option<i64>,
    /// When the body was estimated, ms since the Unix epoch (UTC).
    pub made_at_ms: i64,
    /// The unit lengths are printed in.
    pub unit: Unit,
    /// The operator's readings, in the model's order.
    pub taken: Vec<CardValue>,
    /// Dimensions read off the estimated body (not measured).
    pub from_body: Vec<CardValue>,
    /// The size per garment on the store's chart, when there is one.
    pub sizes: Option<Recommendation>,
    /// The estimated body (metres, station frame).
    pub body: Mesh,
}

impl Card {
    /// The card of an estimate: `report` is the estimator's report of
    /// `body`; `set` is the measurement set the customer was measured with
    /// (the session's; `None` or one the model lacks: `quick`, the
    /// station's), whose members not taken are read off the body, with
    /// every dimension `sizes` used; `sizes` the recommendation on the
    /// store's chart. Session `None`, made now, in centimetres: the caller
    /// sets those it knows.
    pub fn new(
        estimator: &Estimator,
        report: &EstimateReport,
        body: Mesh,
        set: Option<&str>,
        sizes: Option<Recommendation>,
    ) -> Card {
        let defs = &estimator.set().definitions;
        let label = |name: &str| {
            estimator
                .set()
                .index_of(name)
                .map_or_else(|| name.to_string(), |j| defs[j].label.clone())
        };
        let taken: Vec<CardValue> = report
            .inputs
            .iter()
            .map(|c| CardValue {
                name: c.name.clone(),
                label: label(&c.name),
                value_mm: c.value_mm,
                sd_mm: None,
            })
            .collect();
        let mut shown = set
            .and_then(|s| estimator.set_members(s).ok())
            .or_else(|| estimator.set_members("quick").ok())
            .unwrap_or_default();
        if let Some(rec) = &sizes {
            for g in &rec.garments {
                shown.extend(g.readings.iter().map(|r| r.dimension.clone()));
            }
        }
        let others = crate::estimate::sizes::taken_m(report);
        let from_body = report
            .prediction
            .measurements
            .iter()
            .filter(|m| shown.contains(&m.name) && !taken.iter().any(|t| t.name == m.name))
            .filter_map(|m| {
                Some(CardValue {
                    name: m.name.clone(),
                    label: label(&m.name),
                    value_mm: m.step2_mm?,
                    sd_mm: crate::estimate::sizes::body_sd_mm(estimator, report, &others, &m.name),
                })
            })
            .collect();
        Card {
            session: None,
            made_at_ms: crate::store::now_ms(),
            unit: Unit::Cm,
            taken,
            from_body,
            sizes,
            body,
        }
    }
}

/// Why no card was made; the session and its estimate are untouched.
#[derive(Debug, thiserror::Error)]
pub enum CardError {
    /// The body has no finite vertex to draw.
    #[error("the body has no finite vertices to draw on the card: estimate it again")]
    EmptyBody,
    /// The renderer refused the body.
    #[error("drawing the body for the card: {0}")]
    Render(#[from] RenderError),
    /// Deflating an image failed (out of memory).
    #[error("compressing the card's pictures: {0}")]
    Compress(#[source] std::io::Error),
    /// The folder could not be created.
    #[error("cannot create the folder {} for the card: {source}; choose another folder", .path.display())]
    Folder {
        /// The folder.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Writing the file failed (nothing is left under its name).
    #[error("writing the card {}: {source}; check that the folder is writable and has space", .path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
}

/// The card's file name: `session<ID>-card.pdf` (no customer id: the card
/// carries none, its name neither), `card.pdf` without a session.
pub fn file_name(session: Option<i64>) -> String {
    match session {
        Some(id) => format!("session{id}-card.pdf"),
        None => "card.pdf".to_string(),
    }
}

/// Writes `pdf` to `path` atomically (a temporary file in the same folder,
/// then renamed; the folder is created if missing): a reader never sees a
/// half-written card, and a failure leaves an older card as it was.
pub fn write_card(path: &Path, pdf: &[u8]) -> Result<(), CardError> {
    if let Some(dir) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| CardError::Folder {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    tapeshape_common::fs::write_atomic(path, pdf).map_err(|source| CardError::Write {
        path: path.to_path_buf(),
        source,
    })
}

// Page geometry, PDF points (1/72 in), origin bottom left: A4.
const PAGE_W: f32 = 595.276;
const PAGE_H: f32 = 841.89;
const MARGIN: f32 = 42.0;
/// The figures' column on the first page.
const FIG_X: f32 = MARGIN;
const FIG_W: f32 = 240.0;
const FIG_TOP: f32 = 712.0;
const FIG_BOTTOM: f32 = 128.0;
/// Gap between the front and side figures.
const FIG_GAP: f32 = 12.0;
/// Render resolution: image pixels per point (144 dpi).
const PX_PER_PT: f64 = 2.0;
/// The text column on the first page; later pages use the full width.
const COL_X: f32 = 300.0;
const COL_RIGHT: f32 = PAGE_W - MARGIN;
const FIRST_TOP: f32 = 712.0;
const LATER_TOP: f32 = PAGE_H - MARGIN - 30.0;
/// Text stops above the footer.
const TEXT_BOTTOM: f32 = 112.0;
/// The body's colour in the renders (a warm tone no text on the card has).
const BODY_RGB: [u8; 3] = [214, 168, 132];

const REGULAR: Name<'static> = Name(b"F1");
const BOLD: Name<'static> = Name(b"F2");
const OBLIQUE: Name<'static> = Name(b"F3");

/// Helvetica's glyph widths (thousandths of the font size) for WinAnsi
/// codes 32 to 126, from Adobe's published font metrics of the base-14
/// fonts (Helvetica-Oblique has the same widths).
const HELVETICA_ASCII: [u16; 95] = [
    278, 278, 355, 556, 556, 889, 667, 191, 333, 333, 389, 584, 278, 333, 278,
    278, // ' '..'/'
    556, 556, 556, 556, 556, 556, 556, 556, 556, 556, 278, 278, 584, 584, 584,
    556, // '0'..'?'
    1015, 667, 667, 722, 722, 667, 611, 778, 722, 278, 500, 667, 556, 833, 722,
    778, // '@'..'O'
    667, 778, 722, 667, 611, 722, 667, 944, 667, 667, 611, 278, 278, 278, 469,
    556, // 'P'..'_'
    333, 556, 556, 500, 556, 556, 278, 556, 556, 222, 222, 500, 222, 833, 556,
    556, // '`'..'o'
    556, 556, 333, 500, 278, 556, 500, 722, 500, 500, 500, 334, 260, 334, 584, // 'p'..'~'
];

/// The width of one character in Helvetica, thousandths of the font size
/// (the few non-ASCII characters the card uses; others as a digit).
fn glyph_width(c: char) -> u16 {
    match c {
        ' '..='~' => HELVETICA_ASCII[c as usize - 32],
        '±' | '×' => 584,
        '–' => 556,
        '—' | '…' => 1000,
        '·' => 278,
        '°' => 400,
        '•' => 350,
        '’' | '‘' => 222,
        '“' | '”' => 333,
        'ß' => 611,
        'Ä' | 'Á' | 'À' | 'Å' => 667,
        'Ö' | 'Ó' | 'Ò' => 778,
        'Ü' | 'Ú' => 722,
        _ => 556,
    }
}

/// The width of `text` set in Helvetica (or Helvetica-Oblique) at `size`
/// points, in points. Helvetica-Bold runs a few per cent wider in running
/// text (a quarter for the narrowest letters, i and l); the line breaking
/// allows 12 % for it.
pub fn text_width(text: &str, size: f32) -> f32 {
    text.chars().map(|c| f32::from(glyph_width(c))).sum::<f32>() * size / 1000.0
}

/// `text` in WinAnsiEncoding, the base-14 fonts' encoding: ASCII and
/// Latin-1 as they are, the few typographic characters WinAnsi holds
/// (dashes, quotes, bullet, ellipsis, euro) by its codes, anything else as
/// `?`; control characters become spaces.
pub fn win_ansi(text: &str) -> Vec<u8> {
    text.chars()
        .map(|c| match c {
            ' '..='~' => c as u8,
            '\u{a0}'..='\u{ff}' => c as u32 as u8,
            '€' => 0x80,
            '‚' => 0x82,
            '„' => 0x84,
            '…' => 0x85,
            '‘' => 0x91,
            '’' => 0x92,
            '“' => 0x93,
            '”' => 0x94,
            '•' => 0x95,
            '–' => 0x96,
            '—' => 0x97,
            '™' => 0x99,
            c if c.is_control() => b' ',
            _ => b'?',
        })
        .collect()
}

/// Greedy line breaking of `text` at spaces into lines at most `width`
/// points wide in Helvetica at `size` (`bold`: allowing for the wider
/// glyphs); a word wider than a line stands on a line of its own.
fn wrap(text: &str, size: f32, width: f32, bold: bool) -> Vec<String> {
    let factor = if bold { 1.12 } else { 1.0 };
    let fits = |s: &str| text_width(s, size) * factor <= width;
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        let candidate = if line.is_empty() {
            word.to_string()
        } else {
            format!("{line} {word}")
        };
        if fits(&candidate) || line.is_empty() {
            line = candidate;
        } else {
            lines.push(std::mem::take(&mut line));
            line = word.to_string();
        }
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// `text` cut (with `…`) to at most `width` points in Helvetica at `size`.
fn fit(text: &str, size: f32, width: f32) -> String {
    if text_width(text, size) <= width {
        return text.to_string();
    }
    let mut out = String::new();
    for c in text.chars() {
        if text_width(&format!("{out}{c}…"), size) > width {
            break;
        }
        out.push(c);
    }
    format!("{}…", out.trim_end())
}

/// The pages' content streams as they are laid out: a column that flows
/// onto a new page when full.
struct Flow {
    pages: Vec<Content>,
    y: f32,
    x0: f32,
    x1: f32,
}

impl Flow {
    fn page(&mut self) -> &mut Content {
        // `pages` is never empty: `Flow` starts with one.
        let last = self.pages.len() - 1;
        &mut self.pages[last]
    }

    /// Makes room for `height` points, starting a page (full width) when
    /// the column has less left.
    fn room(&mut self, height: f32) {
        if self.y - height < TEXT_BOTTOM {
            self.pages.push(Content::new());
            self.x0 = MARGIN;
            self.x1 = COL_RIGHT;
            self.y = LATER_TOP;
        }
    }

    /// One line of text at `x`, on the current baseline.
    fn text_at(&mut self, x: f32, font: Name, size: f32, grey: f32, text: &str) {
        let y = self.y;
        put_text(self.page(), x, y, font, size, grey, text);
    }

    /// One line of text ending at `right`.
    fn text_right(&mut self, right: f32, size: f32, text: &str) {
        let x = right - text_width(text, size);
        self.text_at(x, REGULAR, size, 0.0, text);
    }

    /// A section heading with some space above it.
    fn heading(&mut self, text: &str) {
        self.y -= 8.0;
        for line in wrap(text, 11.5, self.x1 - self.x0, true) {
            self.room(18.0);
            self.y -= 14.0;
            let x = self.x0;
            self.text_at(x, BOLD, 11.5, 0.0, &line);
        }
        self.y -= 2.0;
    }

    /// A paragraph wrapped to the column, `indent` points in.
    fn paragraph(&mut self, text: &str, font: Name, size: f32, grey: f32, indent: f32) {
        let bold = font == BOLD;
        for line in wrap(text, size, self.x1 - self.x0 - indent, bold) {
            self.room(size * 1.3);
            self.y -= size * 1.3;
            let x = self.x0 + indent;
            self.text_at(x, font, size, grey, &line);
        }
    }
}

fn put_text(c: &mut Content, x: f32, y: f32, font: Name, size: f32, grey: f32, text: &str) {
    c.set_fill_gray(grey);
    c.begin_text();
    c.set_font(font, size);
    c.next_line(x, y);
    c.show(Str(&win_ansi(text)));
    c.end_text();
}

fn rule(c: &mut Content, x0: f32, x1: f32, y: f32) {
    c.set_stroke_gray(0.6);
    c.set_line_width(0.5);
    c.move_to(x0, y);
    c.line_to(x1, y);
    c.stroke();
}

/// `2026-05-02 14:03 UTC`.
fn date_words(ms: i64) -> String {
    let t = crate::text::format_time_ms(ms); // 2026-05-02T14:03:07Z
    format!("{} {} UTC", &t[..10], t.get(11..16).unwrap_or(""))
}

fn unit_words(unit: Unit) -> &'static str {
    match unit {
        Unit::Mm => "millimetres (mm)",
        Unit::Cm => "centimetres (cm)",
        Unit::M => "metres (m)",
        Unit::In => "inches (in)",
    }
}

/// A reading's origin as the card says it, with its spread.
fn source_words(unit: Unit, source: Source) -> String {
    match source {
        Source::Measured { .. } => "measured".to_string(),
        Source::Estimated { sd_mm } => {
            format!("from the body ± {}", format_length_mm(unit, sd_mm))
        }
    }
}

/// The misfits of `size`, in words ("S is tight at the neck"), if any.
fn misfit_words(size: &SizeFit) -> Option<String> {
    let words: Vec<&str> = size
        .placements
        .iter()
        .filter(|p| !p.position.is_inside())
        .map(|p| p.words.as_str())
        .collect();
    (!words.is_empty()).then(|| format!("{} is {}", size.label, words.join(" and ")))
}

/// A garment's recommendation: its headline and the lines under it.
fn garment_lines(unit: Unit, g: &GarmentFit) -> (String, Vec<String>) {
    use tapeshape_sizes::text::percent;
    use tapeshape_sizes::words::place;
    let len = |mm: f64| format_length_mm(unit, mm);
    let mut lines = Vec::new();
    let Some(best) = &g.best else {
        let names: Vec<String> = g
            .missing
            .iter()
            .filter(|m| m.role == Role::Primary)
            .map(|m| place(&m.dimension))
            .collect();
        return (
            format!("{}: no size", g.garment),
            vec![format!(
                "{} neither measured nor read off the body",
                names.join(", ")
            )],
        );
    };
    let head = format!(
        "{}: {} ({})",
        g.garment,
        best.label,
        percent(best.probability)
    );
    match &g.between {
        Some(b) => {
            let other = &b.other;
            let why = match &b.reason {
                BetweenReason::NoSizeHoldsAll => {
                    let mut parts = vec!["no size holds every measurement".to_string()];
                    parts.extend(misfit_words(best));
                    parts.extend(misfit_words(other));
                    parts.join("; ")
                }
                BetweenReason::NearEdge {
                    dimension,
                    value_mm,
                    edge_mm,
                    distance_mm,
                    source,
                } => format!(
                    "{} {} ({}) is {} {} the edge of {} at {}",
                    place(dimension),
                    len(*value_mm),
                    source_words(unit, *source),
                    len(*distance_mm),
                    if value_mm < edge_mm { "below" } else { "above" },
                    best.label,
                    len(*edge_mm)
                ),
            };
            lines.push(format!(
                "or {} ({}): {why}",
                other.label,
                percent(other.probability)
            ));
        }
        None => lines.extend(misfit_words(best)),
    }
    for b in &g.beyond {
        lines.push(format!(
            "beyond the chart: {} {} {} every size",
            place(&b.dimension),
            len(b.by_mm),
            match b.side {
                Side::Below => "below",
                Side::Above => "above",
            }
        ));
    }
    let basis: Vec<String> = g
        .readings
        .iter()
        .map(|r| format!("{} {}", place(&r.dimension), source_words(unit, r.source)))
        .collect();
    if !basis.is_empty() {
        lines.push(format!("from: {}", basis.join(", ")));
    }
    for m in &g.missing {
        lines.push(format!("{}: no value", place(&m.dimension)));
    }
    (head, lines)
}

/// The body's front and side renders at one scale, with their size on the
/// page (points).
struct Figures {
    front: Picture,
    side: Picture,
    front_pt: (f32, f32),
    side_pt: (f32, f32),
}

/// An RGB picture: 8-bit samples, rows top to bottom.
struct Picture {
    rgb: Vec<u8>,
    width: u32,
    height: u32,
}

fn figures(body: &Mesh) -> Result<Figures, CardError> {
    let mut lo: Vec3 = [f64::INFINITY; 3];
    let mut hi: Vec3 = [f64::NEG_INFINITY; 3];
    for v in body
        .vertices
        .iter()
        .filter(|v| v.iter().all(|c| c.is_finite()))
    {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    let span = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    if !span.iter().all(|s| s.is_finite() && *s > 0.0) {
        return Err(CardError::EmptyBody);
    }
    // Points per metre: the body's height fills the column, unless the
    // two views side by side are wider than it.
    let fig_h = f64::from(FIG_TOP - FIG_BOTTOM);
    let fig_w = f64::from(FIG_W - FIG_GAP);
    let scale = (fig_h / span[2]).min(fig_w / (span[0] + span[1]));
    let panel = |view, across: f64| -> Result<_, CardError> {
        let (w_pt, h_pt) = (across * scale, span[2] * scale);
        let img = render_panel(
            body,
            &Colouring::Uniform(BODY_RGB),
            &[],
            &Panel {
                view,
                region: Some((lo, hi)),
                width: (w_pt * PX_PER_PT).ceil().max(1.0) as u32,
                height: (h_pt * PX_PER_PT).ceil().max(1.0) as u32,
                marker_radius: 0,
                labels: false,
            },
        )?;
        let picture = Picture {
            width: img.width(),
            height: img.height(),
            rgb: img.into_raw(),
        };
        Ok((picture, (w_pt as f32, h_pt as f32)))
    };
    let (front, front_pt) = panel(View::Front, span[0])?;
    let (side, side_pt) = panel(View::Right, span[1])?;
    Ok(Figures {
        front,
        side,
        front_pt,
        side_pt,
    })
}

fn deflate(bytes: &[u8]) -> Result<Vec<u8>, CardError> {
    let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(bytes).map_err(CardError::Compress)?;
    e.finish().map_err(CardError::Compress)
}

/// The card as PDF bytes (see the module docs for what it shows). Pure but
/// for the rendering time (a fraction of a second); the caller writes it
/// ([`write_card`]).
pub fn card_pdf(card: &Card) -> Result<Vec<u8>, CardError> {
    let unit = card.unit;
    let figs = figures(&card.body)?;

    // Page 1's header and figures.
    let mut first = Content::new();
    put_text(
        &mut first,
        MARGIN,
        PAGE_H - MARGIN - 18.0,
        BOLD,
        20.0,
        0.0,
        "Your body measurements",
    );
    let session = match card.session {
        Some(id) => format!("Session: {id}"),
        None => "Session: no session".to_string(),
    };
    put_text(
        &mut first,
        MARGIN,
        PAGE_H - MARGIN - 40.0,
        REGULAR,
        10.5,
        0.0,
        &session,
    );
    put_text(
        &mut first,
        MARGIN,
        PAGE_H - MARGIN - 55.0,
        REGULAR,
        10.5,
        0.0,
        &format!("Date: {}", date_words(card.made_at_ms)),
    );
    put_text(
        &mut first,
        COL_X,
        PAGE_H - MARGIN - 40.0,
        REGULAR,
        10.5,
        0.0,
        &format!("Lengths in {}", unit_words(unit)),
    );
    put_text(
        &mut first,
        COL_X,
        PAGE_H - MARGIN - 55.0,
        REGULAR,
        10.5,
        0.0,
        "Measured at a tapeshape fitting-room station",
    );
    rule(&mut first, MARGIN, COL_RIGHT, PAGE_H - MARGIN - 66.0);
    let total_w = figs.front_pt.0 + FIG_GAP + figs.side_pt.0;
    let fx = FIG_X + (FIG_W - total_w).max(0.0) / 2.0;
    let sx = fx + figs.front_pt.0 + FIG_GAP;
    let fy = FIG_TOP - figs.front_pt.1;
    for (name, x, (w, h)) in [
        (Name(b"Im1"), fx, figs.front_pt),
        (Name(b"Im2"), sx, figs.side_pt),
    ] {
        first.save_state();
        first.transform([w, 0.0, 0.0, h, x, fy]);
        first.x_object(name);
        first.restore_state();
    }
    put_text(&mut first, fx, fy - 14.0, OBLIQUE, 9.0, 0.35, "front");
    put_text(&mut first, sx, fy - 14.0, OBLIQUE, 9.0, 0.35, "side");

    // The text column.
    let mut flow = Flow {
        pages: vec![first],
        y: FIRST_TOP + 8.0,
        x0: COL_X,
        x1: COL_RIGHT,
    };
    flow.heading("Measurements taken");
    flow.paragraph("by the operator, with the tape", OBLIQUE, 8.5, 0.35, 0.0);
    for v in &card.taken {
        flow.room(13.0);
        flow.y -= 13.0;
        let (x0, x1) = (flow.x0, flow.x1);
        let label = fit(&v.label, 10.0, x1 - x0 - 70.0);
        flow.text_at(x0, REGULAR, 10.0, 0.0, &label);
        flow.text_right(x1, 10.0, &format_length_mm(unit, v.value_mm));
    }
    if !card.from_body.is_empty() {
        flow.heading("Read off the body");
        flow.paragraph(
            "not measured: read off the body estimated from the measurements \
             taken; ± is one standard deviation of the estimate",
            OBLIQUE,
            8.5,
            0.35,
            0.0,
        );
        for v in &card.from_body {
            flow.room(13.0);
            flow.y -= 13.0;
            let (x0, x1) = (flow.x0, flow.x1);
            let w = x1 - x0;
            let label = fit(&v.label, 10.0, w * 0.37);
            flow.text_at(x0, REGULAR, 10.0, 0.0, &label);
            flow.text_at(x0 + w * 0.39, OBLIQUE, 8.5, 0.35, "from the body");
            flow.text_right(x0 + w * 0.80, 10.0, &format_length_mm(unit, v.value_mm));
            if let Some(sd) = v.sd_mm {
                flow.text_right(x1, 10.0, &format!("± {}", format_length_mm(unit, sd)));
            }
        }
    }
    if let Some(rec) = &card.sizes {
        flow.heading("Sizes");
        flow.paragraph(
            &format!(
                "on the store's chart \"{}\"; a percentage is how likely the size's \
                 intervals hold your measurements",
                rec.chart
            ),
            OBLIQUE,
            8.5,
            0.35,
            0.0,
        );
        for g in &rec.garments {
            let (head, lines) = garment_lines(unit, g);
            flow.y -= 3.0;
            flow.paragraph(&head, BOLD, 10.5, 0.0, 0.0);
            for l in lines {
                flow.paragraph(&l, REGULAR, 8.5, 0.2, 10.0);
            }
        }
    }

    // Footers, now that the number of pages is known.
    let n = flow.pages.len();
    let chart = card
        .sizes
        .as_ref()
        .map(|r| format!(" Sizes come from the store's chart \"{}\".", r.chart))
        .unwrap_or_default();
    let footer = [
        format!(
            "Lengths in {}. The figures show the estimated body in the station's frame \
             (Z up, +Y the body's front, +X the body's right; metres), front and side at \
             one scale: the front seen from +Y (the body's right on the left), the side \
             seen from +X (the front on the right).{chart}",
            unit_words(unit)
        ),
        "This card names no one: it holds only the measurements taken, what was read \
         off the body estimated from them, and the sizes."
            .to_string(),
    ];
    for (i, page) in flow.pages.iter_mut().enumerate() {
        rule(page, MARGIN, COL_RIGHT, TEXT_BOTTOM - 8.0);
        let mut y = TEXT_BOTTOM - 20.0;
        for para in &footer {
            for line in wrap(para, 7.5, COL_RIGHT - MARGIN, false) {
                put_text(page, MARGIN, y, REGULAR, 7.5, 0.35, &line);
                y -= 9.5;
            }
        }
        let mark = format!("tapeshape · page {} of {n}", i + 1);
        put_text(
            page,
            COL_RIGHT - text_width(&mark, 7.5),
            MARGIN - 12.0,
            REGULAR,
            7.5,
            0.35,
            &mark,
        );
        if i > 0 {
            let top = format!(
                "Your body measurements, continued · {}",
                match card.session {
                    Some(id) => format!("session {id}"),
                    None => "no session".into(),
                }
            );
            put_text(page, MARGIN, PAGE_H - MARGIN - 10.0, BOLD, 10.0, 0.0, &top);
        }
    }

    // The document.
    let mut pdf = Pdf::new();
    let mut next = 1;
    let mut id = || {
        let r = Ref::new(next);
        next += 1;
        r
    };
    let catalog = id();
    let tree = id();
    let info = id();
    let fonts = [
        (REGULAR, id(), "Helvetica"),
        (BOLD, id(), "Helvetica-Bold"),
        (OBLIQUE, id(), "Helvetica-Oblique"),
    ];
    let images = [(Name(b"Im1"), id()), (Name(b"Im2"), id())];
    let pages: Vec<(Ref, Ref)> = (0..n).map(|_| (id(), id())).collect();
    pdf.catalog(catalog).pages(tree);
    pdf.pages(tree)
        .kids(pages.iter().map(|p| p.0))
        .count(i32::try_from(n).unwrap_or(i32::MAX));
    pdf.document_info(info)
        .title(TextStr("Body measurement card"))
        .producer(TextStr("tapeshape"));
    for (_, r, base) in fonts {
        pdf.type1_font(r)
            .base_font(Name(base.as_bytes()))
            .encoding_predefined(Name(b"WinAnsiEncoding"));
    }
    for ((_, r), img) in images.iter().zip([&figs.front, &figs.side]) {
        let samples = deflate(&img.rgb)?;
        let mut x = pdf.image_xobject(*r, &samples);
        x.filter(Filter::FlateDecode);
        x.width(i32::try_from(img.width).unwrap_or(i32::MAX));
        x.height(i32::try_from(img.height).unwrap_or(i32::MAX));
        x.color_space().device_rgb();
        x.bits_per_component(8);
        x.finish();
    }
    for (i, (content, (page_id, content_id))) in flow.pages.into_iter().zip(&pages).enumerate() {
        let mut page = pdf.page(*page_id);
        page.media_box(Rect::new(0.0, 0.0, PAGE_W, PAGE_H));
        page.parent(tree);
        page.contents(*content_id);
        let mut res = page.resources();
        {
            let mut f = res.fonts();
            for (name, r, _) in fonts {
                f.pair(name, r);
            }
        }
        if i == 0 {
            let mut x = res.x_objects();
            for (name, r) in images {
                x.pair(name, r);
            }
        }
        res.finish();
        page.finish();
        pdf.stream(*content_id, &content.finish());
    }
    Ok(pdf.finish())
}

#[cfg(test)]
mod tests;
