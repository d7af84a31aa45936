//! Writes the two example size charts, `examples/size-charts/menswear.toml`
//! and `womenswear.toml`, laid on ANSUR II train-split percentiles.
//!
//! ```text
//! cargo run -p tapeshape-sizes --example make_example_charts            # write them
//! cargo run -p tapeshape-sizes --example make_example_charts -- --check # compare only
//! ```
//!
//! Why a program: the charts are EXAMPLES for trying the station and for
//! the size results page, not any brand's chart; a rule written down as
//! code can be checked (`tests/example_charts.rs` runs it and compares its
//! output with the committed files) and re-run when the rule changes.
//!
//! The rule (also in `docs/size-charts.md`), per sex (ANSUR II `male.csv`
//! for menswear, `female.csv` for womenswear), on the train split only
//! (subject ids not divisible by 4; the test split stays for evaluation):
//!
//! * each station dimension is read from the ANSUR II column the quick set
//!   maps it to (`chest` from `chestcircumference`, `inside_leg` from
//!   `crotchheight`, ...), in centimetres;
//! * a primary dimension has a fixed step `s` (an even number of cm, per
//!   garment below); the size holding the median (P50) is centred on the
//!   median rounded to a multiple of `s`, and sizes of width `s` are added
//!   on both sides until the 1st and 99th percentiles (P1, P99) lie inside;
//! * a row garment (shirt, jacket) has one primary dimension; trousers are
//!   the full grid of waist columns by inside-leg rows; a dress moves
//!   chest, waist and hip together along the diagonal (size `k` is the
//!   `k`-th step from the median on every dimension, over the union of the
//!   steps each dimension needs);
//! * a secondary dimension's interval in a size is `[floor(P10),
//!   ceil(P90))` of that dimension over the train subjects whose first
//!   primary dimension (chest; trousers: waist) falls in the size's
//!   interval of it, given only when at least [`MIN_SUBJECTS`] subjects do
//!   (at least 1 cm wide);
//! * labels: letter sizes (`M` holds the median, then `L`, `XL`, `2XL`, ...
//!   and `S`, `XS`, `2XS`, ...), jackets for men by half the chest girth
//!   at the size's centre (`50` for 100 cm, the usual European jacket
//!   number), women's jackets and dresses by the usual German numbers (half
//!   the bust girth at the centre less 6: `40` for 92 cm), trousers by the
//!   waist and inside-leg centres (`W88/L80`, cm).

use std::collections::BTreeMap;
use std::path::PathBuf;

use clap::Parser;
use tapeshape_measure::MeasurementSet;
use tapeshape_population::ansur::{Ansur, Sex, Split};

/// A secondary interval is given only when this many train subjects fall in
/// the size.
pub const MIN_SUBJECTS: usize = 20;

/// The lower and upper percentiles the sizes must cover.
const COVER: (f64, f64) = (0.01, 0.99);

/// A primary dimension and its step.
struct Axis {
    dimension: &'static str,
    step_cm: i64,
}

enum Layout {
    /// One primary dimension.
    Row,
    /// Every combination of the two primary dimensions' steps.
    Grid,
    /// All primary dimensions step together.
    Diagonal,
}

enum Labels {
    /// M, L, XL, 2XL... / S, XS, 2XS...
    Letters,
    /// Half the first axis's centre (men's jackets).
    HalfGirth,
    /// Half the first axis's centre less 6 (German women's sizes).
    GermanWomen,
    /// `W{waist centre}/L{inside-leg centre}`.
    WaistLeg,
}

struct Rule {
    garment: &'static str,
    layout: Layout,
    primary: Vec<Axis>,
    secondary: &'static [&'static str],
    labels: Labels,
}

fn axis(dimension: &'static str, step_cm: i64) -> Axis {
    Axis { dimension, step_cm }
}

fn rules(sex: Sex) -> Vec<Rule> {
    match sex {
        Sex::Male => vec![
            Rule {
                garment: "shirt",
                layout: Layout::Row,
                primary: vec![axis("chest", 8)],
                secondary: &["neck", "arm_length"],
                labels: Labels::Letters,
            },
            Rule {
                garment: "jacket",
                layout: Layout::Row,
                primary: vec![axis("chest", 4)],
                secondary: &["arm_length", "stature"],
                labels: Labels::HalfGirth,
            },
            Rule {
                garment: "trousers",
                layout: Layout::Grid,
                primary: vec![axis("waist", 4), axis("inside_leg", 4)],
                secondary: &["hip"],
                labels: Labels::WaistLeg,
            },
        ],
        Sex::Female => vec![
            Rule {
                garment: "shirt",
                layout: Layout::Row,
                primary: vec![axis("chest", 8)],
                secondary: &["waist", "arm_length"],
                labels: Labels::Letters,
            },
            Rule {
                garment: "jacket",
                layout: Layout::Row,
                primary: vec![axis("chest", 4)],
                secondary: &["arm_length"],
                labels: Labels::GermanWomen,
            },
            Rule {
                garment: "dress",
                layout: Layout::Diagonal,
                primary: vec![axis("chest", 4), axis("waist", 4), axis("hip", 4)],
                secondary: &["stature"],
                labels: Labels::GermanWomen,
            },
            Rule {
                garment: "trousers",
                layout: Layout::Grid,
                primary: vec![axis("waist", 4), axis("inside_leg", 4)],
                secondary: &["hip"],
                labels: Labels::WaistLeg,
            },
        ],
    }
}

/// Linear interpolation between order statistics (R's type 7) of sorted
/// `v` at `p` in [0, 1]. Hand-written: six lines, no crate needed.
fn quantile(sorted: &[f64], p: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * p;
    let i = h.floor() as usize;
    match sorted.get(i + 1) {
        Some(next) => sorted[i] + (h - i as f64) * (next - sorted[i]),
        None => sorted[i],
    }
}

/// The train subjects of one sex: per subject, the station dimensions in cm.
struct People {
    rows: Vec<BTreeMap<&'static str, f64>>,
}

impl People {
    fn load(sex: Sex, dimensions: &[&'static str]) -> Result<People, String> {
        let quick = MeasurementSet::builtin("quick").map_err(|e| e.to_string())?;
        let ansur = Ansur::get().map_err(|e| e.to_string())?;
        let mut columns = Vec::new();
        for &d in dimensions {
            let column = quick
                .definitions
                .iter()
                .find(|x| x.name == d)
                .and_then(|x| x.ansur.clone())
                .ok_or_else(|| format!("the quick set has no ANSUR column for `{d}`"))?;
            ansur.check_column(&column).map_err(|e| e.to_string())?;
            columns.push((d, column));
        }
        let rows = ansur
            .subjects(Some(sex), Split::Train)
            .map(|s| {
                columns
                    .iter()
                    .map(|(d, c)| (*d, s.dim(c).expect("column checked above") * 100.0))
                    .collect()
            })
            .collect();
        Ok(People { rows })
    }

    fn sorted(&self, dimension: &str, keep: impl Fn(&BTreeMap<&str, f64>) -> bool) -> Vec<f64> {
        let mut v: Vec<f64> = self
            .rows
            .iter()
            .filter(|r| keep(r))
            .map(|r| r[dimension])
            .collect();
        v.sort_by(f64::total_cmp);
        v
    }
}

/// One primary dimension's steps: centre of step 0 and the step range.
struct Steps {
    centre_cm: i64,
    step_cm: i64,
    k_min: i64,
    k_max: i64,
}

impl Steps {
    fn of(people: &People, axis: &Axis) -> Steps {
        assert!(
            axis.step_cm % 2 == 0,
            "even steps keep the edges in whole cm"
        );
        let v = people.sorted(axis.dimension, |_| true);
        let s = axis.step_cm;
        let centre_cm = (quantile(&v, 0.5) / s as f64).round() as i64 * s;
        let (p_lo, p_hi) = (quantile(&v, COVER.0), quantile(&v, COVER.1));
        let mut steps = Steps {
            centre_cm,
            step_cm: s,
            k_min: 0,
            k_max: 0,
        };
        while steps.interval(steps.k_min).0 as f64 > p_lo {
            steps.k_min -= 1;
        }
        while steps.interval(steps.k_max).1 as f64 <= p_hi {
            steps.k_max += 1;
        }
        steps
    }

    fn centre(&self, k: i64) -> i64 {
        self.centre_cm + k * self.step_cm
    }

    fn interval(&self, k: i64) -> (i64, i64) {
        let c = self.centre(k);
        (c - self.step_cm / 2, c + self.step_cm / 2)
    }
}

fn letter(k: i64) -> String {
    match k {
        0 => "M".into(),
        1 => "L".into(),
        -1 => "S".into(),
        2 => "XL".into(),
        -2 => "XS".into(),
        k if k > 0 => format!("{}XL", k - 1),
        k => format!("{}XS", -k - 1),
    }
}

/// One size: its label and per primary dimension its step index.
struct Cell {
    label: String,
    ks: Vec<i64>,
}

fn cells(rule: &Rule, steps: &[Steps]) -> Vec<Cell> {
    let label = |ks: &[i64]| match rule.labels {
        Labels::Letters => letter(ks[0]),
        Labels::HalfGirth => format!("{}", steps[0].centre(ks[0]) / 2),
        Labels::GermanWomen => format!("{}", steps[0].centre(ks[0]) / 2 - 6),
        Labels::WaistLeg => format!("W{}/L{}", steps[0].centre(ks[0]), steps[1].centre(ks[1])),
    };
    let ks: Vec<Vec<i64>> = match rule.layout {
        Layout::Row => (steps[0].k_min..=steps[0].k_max).map(|k| vec![k]).collect(),
        Layout::Grid => (steps[0].k_min..=steps[0].k_max)
            .flat_map(|a| (steps[1].k_min..=steps[1].k_max).map(move |b| vec![a, b]))
            .collect(),
        Layout::Diagonal => {
            let lo = steps.iter().map(|s| s.k_min).min().unwrap_or(0);
            let hi = steps.iter().map(|s| s.k_max).max().unwrap_or(0);
            (lo..=hi).map(|k| vec![k; steps.len()]).collect()
        }
    };
    ks.into_iter()
        .map(|ks| Cell {
            label: label(&ks),
            ks,
        })
        .collect()
}

fn quoted(names: &[&str]) -> String {
    let q: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
    format!("[{}]", q.join(", "))
}

fn garment_text(rule: &Rule, people: &People) -> String {
    let steps: Vec<Steps> = rule.primary.iter().map(|a| Steps::of(people, a)).collect();
    let primary: Vec<&str> = rule.primary.iter().map(|a| a.dimension).collect();
    let layout = match rule.layout {
        Layout::Row => "one row of sizes",
        Layout::Grid => "every combination (a grid)",
        Layout::Diagonal => "the dimensions step together (a diagonal)",
    };
    let step_words: Vec<String> = rule
        .primary
        .iter()
        .map(|a| format!("{} {} cm", a.dimension, a.step_cm))
        .collect();
    let mut text = format!(
        "\n# {}: steps {}; {layout}.\n[[garment]]\nname = \"{}\"\nprimary = {}\nsecondary = {}\nsize = [\n",
        rule.garment,
        step_words.join(", "),
        rule.garment,
        quoted(&primary),
        quoted(rule.secondary),
    );
    for cell in cells(rule, &steps) {
        let mut fields = vec![format!("label = \"{}\"", cell.label)];
        let boxes: Vec<(&str, (i64, i64))> = primary
            .iter()
            .zip(&steps)
            .zip(&cell.ks)
            .map(|((d, s), k)| (*d, s.interval(*k)))
            .collect();
        for (d, (lo, hi)) in &boxes {
            fields.push(format!("{d} = [{lo}, {hi}]"));
        }
        // Secondary intervals over the subjects in the size's interval of
        // the first primary dimension (a dress's bust, trousers' waist): a
        // diagonal's full box holds too few people to say anything.
        let (first, (lo, hi)) = boxes[0];
        let inside = |r: &BTreeMap<&str, f64>| lo as f64 <= r[first] && r[first] < hi as f64;
        for d in rule.secondary {
            let v = people.sorted(d, inside);
            if v.len() >= MIN_SUBJECTS {
                let lo = quantile(&v, 0.10).floor() as i64;
                let hi = (quantile(&v, 0.90).ceil() as i64).max(lo + 1);
                fields.push(format!("{d} = [{lo}, {hi}]"));
            }
        }
        text += &format!("    {{ {} }},\n", fields.join(", "));
    }
    text + "]\n"
}

/// The chart file for `sex` (menswear for [`Sex::Male`], womenswear for
/// [`Sex::Female`]).
pub fn chart_text(sex: Sex) -> Result<String, String> {
    let rules = rules(sex);
    let mut dimensions: Vec<&'static str> = Vec::new();
    for r in &rules {
        for d in r
            .primary
            .iter()
            .map(|a| a.dimension)
            .chain(r.secondary.iter().copied())
        {
            if !dimensions.contains(&d) {
                dimensions.push(d);
            }
        }
    }
    let people = People::load(sex, &dimensions)?;
    let (wear, file, who) = match sex {
        Sex::Male => ("menswear", "male.csv", "men"),
        Sex::Female => ("womenswear", "female.csv", "women"),
    };
    let mut text = format!(
        "# EXAMPLE size chart ({wear}), NOT any brand's or store's chart.\n\
         #\n\
         # Built by host/sizes/examples/make_example_charts.rs from a documented rule\n\
         # (docs/size-charts.md, \"The example charts\"): intervals laid on ANSUR II\n\
         # percentiles of the {} train-split {who} (ANSUR II {file}, subject ids\n\
         # not divisible by 4). Per primary dimension a fixed step, the size holding\n\
         # the median centred on it (rounded to a multiple of the step), sizes added\n\
         # until P1 and P99 are inside; a secondary interval is [floor(P10), ceil(P90))\n\
         # of the subjects whose first primary dimension falls in the size's interval\n\
         # of it (given when at least {MIN_SUBJECTS} do).\n\
         # Regenerate: cargo run -p tapeshape-sizes --example make_example_charts\n\
         # Dimensions are the station's measurement names (host/measure/sets/quick.toml).\n\
         \n\
         [chart]\n\
         name = \"Example {wear} (ANSUR II train-split percentiles; not a brand's chart)\"\n\
         units = \"cm\"\n\
         description = \"An example built from ANSUR II percentiles of {} {who} by the rule in docs/size-charts.md, for trying the station; not any brand's chart.\"\n",
        people.rows.len(),
        people.rows.len(),
    );
    for rule in &rules {
        text += &garment_text(rule, &people);
    }
    Ok(text)
}

/// Where the charts go: `examples/size-charts/` at the workspace root.
pub fn chart_path(sex: Sex) -> PathBuf {
    let name = match sex {
        Sex::Male => "menswear.toml",
        Sex::Female => "womenswear.toml",
    };
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/size-charts")
        .join(name)
}

/// Writes the two example size charts, `examples/size-charts/menswear.toml`
/// and `womenswear.toml`, laid on ANSUR II train-split percentiles.
#[derive(Parser)]
// `--check` given twice is still `--check`, as the hand-written lookup took it.
#[command(args_override_self = true)]
struct Args {
    /// Compare only: write nothing, and fail when a committed chart differs
    /// from what this program would write.
    #[arg(long)]
    check: bool,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Args { check } = tapeshape_common::cli::parse_or_exit::<Args>();
    let mut stale = Vec::new();
    for sex in [Sex::Male, Sex::Female] {
        let text = chart_text(sex)?;
        let path = chart_path(sex);
        if check {
            if std::fs::read_to_string(&path).ok().as_deref() != Some(text.as_str()) {
                stale.push(path.display().to_string());
            }
        } else {
            tapeshape_common::fs::write_atomic(&path, text.as_bytes())?;
            println!("wrote {}", path.display());
        }
    }
    if !stale.is_empty() {
        return Err(format!(
            "out of date (regenerate with `cargo run -p tapeshape-sizes --example make_example_charts`): {}",
            stale.join(", ")
        )
        .into());
    }
    Ok(())
}
