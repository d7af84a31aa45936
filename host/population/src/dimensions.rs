//! Every dimension of the `ansur` measurement set beside ANSUR II (issue 12):
//! how far a population's per-sex means, SDs and correlations are from the
//! train split's on all the dimensions a body model is asked about, not only
//! the four of issue 3's check ([`crate::statistics`]), and how many bodies
//! match their own ANSUR II subject within the ISO 20685-1 allowable error.
//!
//! Why a report of its own: issue 3's check holds four dimensions to tight
//! bounds; a population fitted on 12 or 26 dimensions leaves the others to
//! the generator's correlations, and only a comparison over all of them says
//! which ones a model trained on the population will get wrong. A 44 x 44
//! correlation matrix pair is unreadable, so correlations are summarised
//! ([`CorrelationSummary`]: the largest and mean gap, the share of pairs
//! within issue 3's 0.15, the worst pairs).
//!
//! Values are measured on each body's stored mesh with the `ansur` set (not
//! taken from the fit records). The per-subject comparison uses the subject
//! recorded in each body's record (`BodyRecord::ansur_subject`); a body
//! whose subject is missing is left out of it with a note
//! ([`SkippedBody`]), never dropped silently.
//!
//! Units: millimetres in the report (means, SDs, tolerances, errors);
//! correlations and shares dimensionless; relative differences as ratios
//! minus one.

use std::collections::BTreeSet;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use tapeshape_body::BodyModel;
use tapeshape_measure::MeasurementSet;

use crate::ansur::{Ansur, Sex, Split, Subject};
use crate::format::{BodyRecord, Dataset};
use crate::generate::FitScope;
use crate::statistics::mean_sd_corr;
use crate::DatasetError;

/// A correlation pair is "within" when its population and ANSUR II
/// coefficients differ by at most this (issue 3's bound).
pub const CORRELATION_BOUND: f64 = 0.15;

/// How many of the worst correlation pairs the report lists per sex.
pub const WORST_PAIRS: usize = 10;

/// One compared dimension: a measurement of the `ansur` set that follows an
/// ANSUR II column.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Dimension {
    /// Measurement name in the `ansur` set.
    pub name: String,
    /// The ANSUR II column it follows.
    pub column: String,
    /// ISO 20685-1 allowable error of the definition (mm).
    pub tolerance_mm: f64,
    /// Targeted by the fit of every body judged against its subject.
    pub fitted: bool,
    /// Named in the caller's list of columns a standing skin mesh cannot
    /// take as ANSUR II does (the station passes the estimator's
    /// `CANNOT_FOLLOW_ANSUR`).
    pub cannot_follow: bool,
}

/// A body left out of part of the report, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkippedBody {
    /// The body's name in the dataset.
    pub name: String,
    /// Left out of everything (`true`: no sex, or its mesh could not be
    /// measured) or only of the comparison with its subject (`false`).
    pub everywhere: bool,
    /// What was wrong, and what to do about it.
    pub reason: String,
}

/// One pair of dimensions with both correlation coefficients.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CorrelationPair {
    /// First dimension (earlier in set order).
    pub a: String,
    /// Second dimension.
    pub b: String,
    /// Pearson r over the population's bodies.
    pub population: f64,
    /// Pearson r over the ANSUR II train-split subjects.
    pub ansur: f64,
}

impl CorrelationPair {
    /// `population - ansur`.
    pub fn diff(&self) -> f64 {
        self.population - self.ansur
    }
}

/// The gap between two correlation matrices of the same dimensions, over
/// the pairs above the diagonal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CorrelationSummary {
    /// Pairs `a < b` with both coefficients defined (`k (k - 1) / 2` when
    /// none is NaN).
    pub n_pairs: usize,
    /// Pairs where either coefficient is NaN (a constant dimension); not
    /// counted anywhere else.
    pub n_undefined: usize,
    /// Largest |population r - ANSUR r| (`None` without pairs).
    pub max_abs_diff: Option<f64>,
    /// Mean |population r - ANSUR r| (`None` without pairs).
    pub mean_abs_diff: Option<f64>,
    /// The bound used for `n_within`.
    pub bound: f64,
    /// Pairs with |population r - ANSUR r| <= `bound`.
    pub n_within: usize,
    /// The pairs with the largest |difference|, largest first (ties in set
    /// order).
    pub worst: Vec<CorrelationPair>,
}

/// Summarises the gap between `corr` and `ansur_corr` (both `k x k`, over
/// the dimensions `names`, length `k`): the pairs above the diagonal, the
/// share within `bound`, and the `n_worst` pairs with the largest gap.
///
/// # Panics
///
/// If the matrices are not `k x k` (a programming error, not input).
pub fn correlation_summary(
    names: &[String],
    corr: &[Vec<f64>],
    ansur_corr: &[Vec<f64>],
    bound: f64,
    n_worst: usize,
) -> CorrelationSummary {
    let k = names.len();
    assert!(
        corr.len() == k
            && ansur_corr.len() == k
            && corr.iter().chain(ansur_corr).all(|r| r.len() == k),
        "correlation matrices must be {k} x {k}"
    );
    let mut pairs = Vec::new();
    let mut n_undefined = 0;
    for a in 0..k {
        for b in a + 1..k {
            let (p, q) = (corr[a][b], ansur_corr[a][b]);
            if p.is_nan() || q.is_nan() {
                n_undefined += 1;
                continue;
            }
            pairs.push(CorrelationPair {
                a: names[a].clone(),
                b: names[b].clone(),
                population: p,
                ansur: q,
            });
        }
    }
    let n_pairs = pairs.len();
    let abs: Vec<f64> = pairs.iter().map(|p| p.diff().abs()).collect();
    let max_abs_diff = abs.iter().copied().reduce(f64::max);
    let mean_abs_diff = (n_pairs > 0).then(|| abs.iter().sum::<f64>() / n_pairs as f64);
    let n_within = abs.iter().filter(|&&d| d <= bound).count();
    // Stable sort: equal gaps keep set order.
    pairs.sort_by(|x, y| y.diff().abs().total_cmp(&x.diff().abs()));
    pairs.truncate(n_worst);
    CorrelationSummary {
        n_pairs,
        n_undefined,
        max_abs_diff,
        mean_abs_diff,
        bound,
        n_within,
        worst: pairs,
    }
}

/// One body judged against its ANSUR II subject.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BodyIso {
    /// The body's name in the dataset.
    pub name: String,
    /// Its ANSUR II subject id.
    pub subject: u32,
    /// Dimensions (measurement names) whose value on the mesh is outside
    /// the ISO 20685-1 allowable error of the subject's real value, in set
    /// order.
    pub outside: Vec<String>,
    /// Of `outside`, how many the body's fit targeted.
    pub outside_fitted: usize,
}

/// The bodies of one sex against their own ANSUR II subjects, judged with
/// each dimension's ISO 20685-1 allowable error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IsoSummary {
    /// Bodies judged (those with a known subject and fit scope).
    pub n_judged: usize,
    /// Per dimension (report order): bodies within the allowable error.
    pub within: Vec<usize>,
    /// Per dimension: mean |mesh value - subject's value| (mm; `None`
    /// without judged bodies).
    pub mean_abs_error_mm: Vec<Option<f64>>,
    /// Bodies within the allowable error on every dimension their fit
    /// targeted.
    pub within_all_fitted: usize,
    /// Bodies within on every dimension not marked `cannot_follow`
    /// (`None` when no dimension is marked).
    pub within_all_followable: Option<usize>,
    /// Bodies within on every dimension.
    pub within_all: usize,
    /// Every judged body, in dataset order.
    pub bodies: Vec<BodyIso>,
}

/// Input of [`judge_iso`]: one body's values, in report order.
#[derive(Debug, Clone)]
struct IsoBody {
    name: String,
    subject: u32,
    /// Measured on the mesh, metres.
    measured_m: Vec<f64>,
    /// The subject's real values, metres.
    real_m: Vec<f64>,
    /// Whether the body's fit targeted each dimension.
    fitted: Vec<bool>,
}

/// Judges `bodies` against their subjects (see [`IsoSummary`]), as the
/// evaluation of real customers does: within when |mesh - real| <= the
/// definition's allowable error.
fn judge_iso(dimensions: &[Dimension], bodies: &[IsoBody]) -> IsoSummary {
    let k = dimensions.len();
    let mut within = vec![0; k];
    let mut abs_sum_mm = vec![0.0; k];
    let any_cannot = dimensions.iter().any(|d| d.cannot_follow);
    let (mut all_fitted, mut all_followable, mut all) = (0, 0, 0);
    let mut judged = Vec::with_capacity(bodies.len());
    for b in bodies {
        let mut outside = Vec::new();
        let mut outside_fitted = 0;
        let mut outside_followable = 0;
        for (j, d) in dimensions.iter().enumerate() {
            let err_m = (b.measured_m[j] - b.real_m[j]).abs();
            abs_sum_mm[j] += err_m * 1000.0;
            // NaN (never expected) counts as outside.
            if err_m <= d.tolerance_mm / 1000.0 {
                within[j] += 1;
            } else {
                outside.push(d.name.clone());
                outside_fitted += usize::from(b.fitted[j]);
                outside_followable += usize::from(!d.cannot_follow);
            }
        }
        all_fitted += usize::from(outside_fitted == 0);
        all_followable += usize::from(outside_followable == 0);
        all += usize::from(outside.is_empty());
        judged.push(BodyIso {
            name: b.name.clone(),
            subject: b.subject,
            outside,
            outside_fitted,
        });
    }
    let n = bodies.len();
    IsoSummary {
        n_judged: n,
        within,
        mean_abs_error_mm: abs_sum_mm
            .iter()
            .map(|s| (n > 0).then(|| s / n as f64))
            .collect(),
        within_all_fitted: all_fitted,
        within_all_followable: any_cannot.then_some(all_followable),
        within_all: all,
        bodies: judged,
    }
}

/// One sex: population beside ANSUR II on every dimension, and its bodies
/// against their subjects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SexDimensions {
    /// Which sex.
    pub sex: Sex,
    /// Bodies of this sex measured.
    pub n_bodies: usize,
    /// Train-split subjects of this sex aged 18-90.
    pub n_ansur: usize,
    /// Population mean per dimension (mm), report order.
    pub mean_mm: Vec<f64>,
    /// ANSUR II train mean per dimension (mm).
    pub ansur_mean_mm: Vec<f64>,
    /// Population sample SD per dimension (mm).
    pub sd_mm: Vec<f64>,
    /// ANSUR II train sample SD per dimension (mm).
    pub ansur_sd_mm: Vec<f64>,
    /// Population correlation matrix (`k x k`).
    pub corr: Vec<Vec<f64>>,
    /// ANSUR II train correlation matrix (`k x k`).
    pub ansur_corr: Vec<Vec<f64>>,
    /// The gap between the two matrices.
    pub correlation: CorrelationSummary,
    /// The same over the dimensions not marked `cannot_follow` (`None`
    /// when none is marked).
    pub correlation_followable: Option<CorrelationSummary>,
    /// The bodies against their own subjects.
    pub iso: IsoSummary,
}

impl SexDimensions {
    /// Relative mean difference of dimension `j` (population / ANSUR - 1).
    pub fn mean_diff(&self, j: usize) -> f64 {
        self.mean_mm[j] / self.ansur_mean_mm[j] - 1.0
    }

    /// Relative SD difference of dimension `j` (population / ANSUR - 1).
    pub fn sd_diff(&self, j: usize) -> f64 {
        self.sd_mm[j] / self.ansur_sd_mm[j] - 1.0
    }
}

/// A fit record's achieved value differs from the stored mesh's "notably"
/// above this (mm): f32 storage alone gives about 0.001 mm.
pub const RECORD_GAP_MM: f64 = 0.1;

/// One fitted dimension re-measured on the stored meshes against the fit
/// records' achieved values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RecordGap {
    /// Measurement name.
    pub dimension: String,
    /// Bodies whose fit record holds the dimension.
    pub n_bodies: usize,
    /// Largest |mesh value - achieved value| (mm).
    pub max_mm: f64,
    /// The body with the largest difference.
    pub worst_body: String,
    /// Bodies whose difference exceeds [`RECORD_GAP_MM`].
    pub n_over: usize,
}

/// The whole comparison: the dimensions, then one block per sex with at
/// least three bodies.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DimensionReport {
    /// Compared dimensions, in `ansur` set order.
    pub dimensions: Vec<Dimension>,
    /// The fit scope the file's header records (`None`: not recorded).
    pub fit_scope: Option<FitScope>,
    /// Per fitted dimension, the value measured on the stored mesh against
    /// the fit record's achieved value: a check that the file's meshes
    /// measure as the fitter saw them (f32 storage alone moves a value by
    /// micrometres; more means a measurement that jumps under round-off).
    /// Dimensions without fit records are left out.
    pub record_gaps: Vec<RecordGap>,
    /// Male, then female (a sex with fewer than three bodies is left out).
    pub sexes: Vec<SexDimensions>,
    /// Bodies left out of part of the report.
    pub skipped: Vec<SkippedBody>,
    /// What else was left out (a sex with fewer than three bodies).
    pub notes: Vec<String>,
}

/// Measures every measurement of the `ansur` set that follows an ANSUR II
/// column on every body of `dataset` (in parallel) and compares, per sex,
/// with ANSUR II's train split (subjects aged 18-90), and each body with its
/// own subject (see the module docs). `cannot_follow`: ANSUR II columns to
/// mark as not measurable on a skin mesh as ANSUR II defines them (may be
/// empty).
///
/// Errors: bodies not in the template topology, a `cannot_follow` name that
/// is no compared column, ANSUR II or the set unreadable. A body that
/// cannot be compared is noted in [`DimensionReport::skipped`], not an
/// error.
pub fn dimension_statistics(
    dataset: &Dataset,
    cannot_follow: &[&str],
) -> Result<DimensionReport, DatasetError> {
    let body = BodyModel::shared()?;
    if dataset.topology.n_vertices() != body.topology().n_vertices() {
        return Err(DatasetError::Settings(format!(
            "the dimension comparison measures bodies in the template topology ({} vertices); this dataset's have {} (a face or imported dataset? use a population from `tapeshape dataset generate`)",
            body.topology().n_vertices(),
            dataset.topology.n_vertices()
        )));
    }
    if dataset.header.bodies.len() != dataset.bodies.len() {
        return Err(DatasetError::Settings(format!(
            "the dataset has {} body records but {} meshes; rewrite it with `tapeshape dataset generate`",
            dataset.header.bodies.len(),
            dataset.bodies.len()
        )));
    }
    let ansur = Ansur::get()?;
    let set = MeasurementSet::builtin("ansur")?
        .compile(body.topology(), &tapeshape_body::anatomy::anatomy())?;
    let defs = &set.set().definitions;
    let index: Vec<usize> = (0..defs.len())
        .filter(|&i| defs[i].ansur.is_some())
        .collect();
    let mut dimensions = Vec::with_capacity(index.len());
    for &i in &index {
        let column = defs[i].ansur.clone().expect("filtered on ansur");
        ansur.check_column(&column)?;
        dimensions.push(Dimension {
            name: defs[i].name.clone(),
            cannot_follow: cannot_follow.contains(&column.as_str()),
            column,
            tolerance_mm: defs[i].tolerance.mm(),
            fitted: false,
        });
    }
    if let Some(bad) = cannot_follow
        .iter()
        .find(|c| !dimensions.iter().any(|d| d.column == **c))
    {
        return Err(DatasetError::Settings(format!(
            "{bad:?}, named as a dimension a mesh cannot follow, is no ANSUR II column of the `ansur` set"
        )));
    }
    let fit_scope = dataset.header.settings.as_ref().map(|s| s.fit);

    // Measure every body (metres), in parallel.
    let measured: Vec<Result<Vec<f64>, String>> = dataset
        .bodies
        .par_iter()
        .map(|b| {
            let m = set.measure(b).map_err(|e| e.to_string())?;
            Ok(index.iter().map(|&i| m[i].value).collect())
        })
        .collect();

    let mut skipped = Vec::new();
    let mut record_gaps: Vec<RecordGap> = dimensions
        .iter()
        .map(|d| RecordGap {
            dimension: d.name.clone(),
            n_bodies: 0,
            max_mm: 0.0,
            worst_body: String::new(),
            n_over: 0,
        })
        .collect();
    let mut per_sex: Vec<(Sex, Vec<Vec<f64>>, Vec<IsoBody>)> = Vec::new();
    for sex in [Sex::Male, Sex::Female] {
        per_sex.push((sex, Vec::new(), Vec::new()));
    }
    for (rec, values) in dataset.header.bodies.iter().zip(measured) {
        let values = match values {
            Ok(v) => v,
            Err(e) => {
                skipped.push(SkippedBody {
                    name: rec.name.clone(),
                    everywhere: true,
                    reason: format!("its mesh could not be measured ({e}): left out of everything (a damaged body; regenerate the file)"),
                });
                continue;
            }
        };
        let Some(sex) = rec.sex else {
            skipped.push(SkippedBody {
                name: rec.name.clone(),
                everywhere: true,
                reason: "its record has no sex, and every comparison is per sex: left out of everything (compare populations made by `tapeshape dataset generate`)".into(),
            });
            continue;
        };
        if let Some(fit) = &rec.fit {
            for ((d, v), g) in dimensions.iter().zip(&values).zip(&mut record_gaps) {
                if let Some(a) = fit.achieved_mm.get(&d.column) {
                    let gap = (v * 1000.0 - a).abs();
                    g.n_bodies += 1;
                    g.n_over += usize::from(gap > RECORD_GAP_MM);
                    if gap > g.max_mm || g.worst_body.is_empty() {
                        g.max_mm = gap;
                        g.worst_body = rec.name.clone();
                    }
                }
            }
        }
        let iso = iso_body(rec, sex, &values, &dimensions, ansur, fit_scope);
        let slot = per_sex
            .iter_mut()
            .find(|(s, _, _)| *s == sex)
            .expect("both sexes listed");
        match iso {
            Ok(b) => slot.2.push(b),
            Err(reason) => skipped.push(SkippedBody {
                name: rec.name.clone(),
                everywhere: false,
                reason,
            }),
        }
        slot.1.push(values);
    }

    // A dimension is "fitted" when every judged body's fit targeted it.
    let judged: Vec<&IsoBody> = per_sex.iter().flat_map(|(_, _, b)| b).collect();
    for (j, d) in dimensions.iter_mut().enumerate() {
        d.fitted = !judged.is_empty() && judged.iter().all(|b| b.fitted[j]);
    }

    let names: Vec<String> = dimensions.iter().map(|d| d.name.clone()).collect();
    let columns: Vec<&str> = dimensions.iter().map(|d| d.column.as_str()).collect();
    let mut notes = Vec::new();
    let mut sexes = Vec::new();
    for (sex, rows, iso_bodies) in per_sex {
        if rows.len() < 3 {
            if !rows.is_empty() {
                notes.push(format!(
                    "{} {} bodies only: fewer than three give no SD or correlation, so that sex is left out",
                    rows.len(),
                    sex.word()
                ));
            }
            continue;
        }
        let subjects: Vec<&Subject> = ansur
            .subjects(Some(sex), Split::Train)
            .filter(|s| (18.0..=90.0).contains(&s.age_years))
            .collect();
        let (mean, sd, corr) = mean_sd_corr(&rows);
        let (ansur_mean, ansur_sd, ansur_corr) = crate::ansur::statistics(&subjects, &columns);
        let mm = |v: Vec<f64>| v.into_iter().map(|x| x * 1000.0).collect::<Vec<f64>>();
        let correlation =
            correlation_summary(&names, &corr, &ansur_corr, CORRELATION_BOUND, WORST_PAIRS);
        let correlation_followable = dimensions.iter().any(|d| d.cannot_follow).then(|| {
            let keep: Vec<usize> = (0..dimensions.len())
                .filter(|&j| !dimensions[j].cannot_follow)
                .collect();
            let sub = |m: &[Vec<f64>]| -> Vec<Vec<f64>> {
                keep.iter()
                    .map(|&a| keep.iter().map(|&b| m[a][b]).collect())
                    .collect()
            };
            let kept: Vec<String> = keep.iter().map(|&j| names[j].clone()).collect();
            correlation_summary(
                &kept,
                &sub(&corr),
                &sub(&ansur_corr),
                CORRELATION_BOUND,
                WORST_PAIRS,
            )
        });
        sexes.push(SexDimensions {
            sex,
            n_bodies: rows.len(),
            n_ansur: subjects.len(),
            mean_mm: mm(mean),
            ansur_mean_mm: mm(ansur_mean),
            sd_mm: mm(sd),
            ansur_sd_mm: mm(ansur_sd),
            corr,
            ansur_corr,
            correlation,
            correlation_followable,
            iso: judge_iso(&dimensions, &iso_bodies),
        });
    }
    Ok(DimensionReport {
        dimensions,
        fit_scope,
        record_gaps: record_gaps.into_iter().filter(|g| g.n_bodies > 0).collect(),
        sexes,
        skipped,
        notes,
    })
}

/// The ISO input of one body, or why it cannot be judged.
fn iso_body(
    rec: &BodyRecord,
    sex: Sex,
    values: &[f64],
    dimensions: &[Dimension],
    ansur: &Ansur,
    fit_scope: Option<FitScope>,
) -> Result<IsoBody, String> {
    let id = rec.ansur_subject.ok_or_else(|| {
        "its record names no ANSUR II subject: left out of the comparison with subjects".to_string()
    })?;
    let subject = ansur.subject(id).ok_or_else(|| {
        format!("its subject {id} is not in the embedded ANSUR II: left out of the comparison with subjects (a file from another program or a damaged header; regenerate it with `tapeshape dataset generate`)")
    })?;
    if subject.sex != sex {
        return Err(format!(
            "its record says {} but ANSUR II subject {id} is {}: left out of the comparison with subjects (a damaged header; regenerate the file)",
            sex.word(),
            subject.sex.word()
        ));
    }
    let fitted_columns: BTreeSet<String> = match (&rec.fit, fit_scope) {
        (Some(fit), _) => fit.target_mm.keys().cloned().collect(),
        (None, Some(scope)) => scope.targets().iter().map(|(c, _)| c.to_string()).collect(),
        (None, None) => {
            return Err("no fit record and no fit scope in the header: which dimensions were fitted is unknown, so it is left out of the comparison with subjects".into())
        }
    };
    let real_m = dimensions
        .iter()
        .map(|d| {
            subject.dim(&d.column).ok_or_else(|| {
                format!(
                    "ANSUR II subject {id} has no {}: left out of the comparison with subjects",
                    d.column
                )
            })
        })
        .collect::<Result<Vec<f64>, String>>()?;
    Ok(IsoBody {
        name: rec.name.clone(),
        subject: id,
        measured_m: values.to_vec(),
        real_m,
        fitted: dimensions
            .iter()
            .map(|d| fitted_columns.contains(&d.column))
            .collect(),
    })
}

/// Share `n / of` as a percentage with one decimal, or `-` when `of` is 0.
fn percent(n: usize, of: usize) -> String {
    if of == 0 {
        "-".into()
    } else {
        format!("{:.1} %", 100.0 * n as f64 / of as f64)
    }
}

/// One correlation summary in words: largest and mean gap, pairs within.
fn correlation_line(c: &CorrelationSummary) -> String {
    format!(
        "largest |population r - ANSUR r| {}, mean {}, within {}: {} of {} ({}){}",
        c.max_abs_diff.map_or("-".into(), |x| format!("{x:.3}")),
        c.mean_abs_diff.map_or("-".into(), |x| format!("{x:.3}")),
        c.bound,
        c.n_within,
        c.n_pairs,
        percent(c.n_within, c.n_pairs),
        if c.n_undefined > 0 {
            format!(", {} pairs undefined (a constant dimension)", c.n_undefined)
        } else {
            String::new()
        }
    )
}

/// The report as Markdown: per sex, one table of every dimension (means,
/// SDs, share within ISO 20685-1 of the body's own subject), the
/// correlation summary and its worst pairs, the count of bodies within ISO
/// on all fitted / followable / all dimensions; then the skipped bodies.
pub fn dimension_markdown(report: &DimensionReport) -> String {
    use std::fmt::Write as _;
    let dims = &report.dimensions;
    let k = dims.len();
    let n_fitted = dims.iter().filter(|d| d.fitted).count();
    let n_cannot = dims.iter().filter(|d| d.cannot_follow).count();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\n### Every `ansur` dimension beside ANSUR II\n\n{k} measurements of the `ansur` set that follow an ANSUR II column, measured on each body's mesh; ANSUR II statistics over the train-split subjects aged 18-90 of each sex. `fit`: targeted by every body's fit ({n_fitted} dimensions; the header records fit scope {}). \"Within ISO\": share of bodies whose mesh value is within the definition's ISO 20685-1 allowable error (`tol`) of their own ANSUR II subject's value; \"abs err\": mean |mesh - subject|.{}",
        match report.fit_scope {
            Some(FitScope::Twelve) => "`twelve`",
            Some(FitScope::Ansur) => "`ansur`",
            Some(FitScope::AnsurSections) => "`ansur-sections`",
            None => "none",
        },
        if n_cannot > 0 {
            let marked: Vec<&str> = dims
                .iter()
                .filter(|d| d.cannot_follow)
                .map(|d| d.name.as_str())
                .collect();
            format!(
                " `*`: a standing skin mesh cannot take it as ANSUR II does ({}).",
                marked.join(", ")
            )
        } else {
            String::new()
        }
    );
    if let Some(worst) = report
        .record_gaps
        .iter()
        .max_by(|a, b| a.max_mm.total_cmp(&b.max_mm))
    {
        let over: Vec<String> = report
            .record_gaps
            .iter()
            .filter(|g| g.n_over > 0)
            .map(|g| format!("{} on {} of {} bodies", g.dimension, g.n_over, g.n_bodies))
            .collect();
        let _ = writeln!(
            s,
            "\nFitted dimensions re-measured on the stored meshes against the fit records' achieved values: largest difference {:.3} mm ({}, {}); more than {RECORD_GAP_MM} mm: {}.",
            worst.max_mm,
            worst.dimension,
            worst.worst_body,
            if over.is_empty() {
                "none".to_string()
            } else {
                over.join(", ")
            }
        );
    }
    for st in &report.sexes {
        let _ = writeln!(
            s,
            "\n#### {:?}: {} bodies vs {} ANSUR II train-split subjects, {} judged against their own subject\n",
            st.sex, st.n_bodies, st.n_ansur, st.iso.n_judged
        );
        s += "| dimension | fit | tol (mm) | mean (mm) | ANSUR mean | diff | SD (mm) | ANSUR SD | diff | within ISO | abs err (mm) |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
        for (j, d) in dims.iter().enumerate() {
            let _ = writeln!(
                s,
                "| {}{} | {} | {:.0} | {:.1} | {:.1} | {:+.2} % | {:.1} | {:.1} | {:+.1} % | {} | {} |",
                d.name,
                if d.cannot_follow { " *" } else { "" },
                if d.fitted { "fit" } else { "" },
                d.tolerance_mm,
                st.mean_mm[j],
                st.ansur_mean_mm[j],
                st.mean_diff(j) * 100.0,
                st.sd_mm[j],
                st.ansur_sd_mm[j],
                st.sd_diff(j) * 100.0,
                percent(st.iso.within[j], st.iso.n_judged),
                st.iso.mean_abs_error_mm[j].map_or("-".into(), |e| format!("{e:.1}")),
            );
        }
        let worst = |f: &dyn Fn(usize) -> f64, followable_only: bool| {
            (0..k)
                .filter(|&j| !followable_only || !dims[j].cannot_follow)
                .max_by(|&a, &b| f(a).abs().total_cmp(&f(b).abs()))
        };
        for (what, f) in [
            ("mean", &(|j| st.mean_diff(j)) as &dyn Fn(usize) -> f64),
            ("SD", &|j| st.sd_diff(j)),
        ] {
            if let Some(j) = worst(f, false) {
                let _ = write!(
                    s,
                    "\nLargest {what} difference: {} ({:+.1} %)",
                    dims[j].name,
                    f(j) * 100.0
                );
                if dims[j].cannot_follow {
                    if let Some(i) = worst(f, true) {
                        let _ = write!(
                            s,
                            "; without the `*` dimensions: {} ({:+.1} %)",
                            dims[i].name,
                            f(i) * 100.0
                        );
                    }
                }
                s += ".\n";
            }
        }
        let c = &st.correlation;
        let _ = write!(
            s,
            "\nCorrelations over the {} pairs of {k} dimensions: {}",
            c.n_pairs,
            correlation_line(c)
        );
        if let Some(f) = &st.correlation_followable {
            let _ = write!(
                s,
                "; over the {} pairs without `*`: {}",
                f.n_pairs,
                correlation_line(f)
            );
        }
        s += ".\n";
        if !c.worst.is_empty() {
            let _ = writeln!(
                s,
                "\nThe {} pairs furthest from ANSUR II:\n\n| pair | population r | ANSUR r | diff |\n|---|---:|---:|---:|",
                c.worst.len()
            );
            for p in &c.worst {
                let star = |name: &str| {
                    if dims.iter().any(|d| d.name == name && d.cannot_follow) {
                        " *"
                    } else {
                        ""
                    }
                };
                let _ = writeln!(
                    s,
                    "| {}{} - {}{} | {:.2} | {:.2} | {:+.2} |",
                    p.a,
                    star(&p.a),
                    p.b,
                    star(&p.b),
                    p.population,
                    p.ansur,
                    p.diff()
                );
            }
        }
        let iso = &st.iso;
        let _ = write!(
            s,
            "\nWithin ISO 20685-1 of their own subject: on every dimension their fit targeted ({n_fitted}) {} of {} bodies ({})",
            iso.within_all_fitted,
            iso.n_judged,
            percent(iso.within_all_fitted, iso.n_judged)
        );
        if let Some(n) = iso.within_all_followable {
            let _ = write!(
                s,
                "; on all {} dimensions without `*` {} ({})",
                k - n_cannot,
                n,
                percent(n, iso.n_judged)
            );
        }
        let _ = writeln!(
            s,
            "; on all {k} dimensions {} ({}).",
            iso.within_all,
            percent(iso.within_all, iso.n_judged)
        );
    }
    for n in &report.notes {
        let _ = writeln!(s, "\nNote: {n}.");
    }
    if !report.skipped.is_empty() {
        let _ = writeln!(s, "\n{} bodies left out:\n", report.skipped.len());
        for b in report.skipped.iter().take(20) {
            let _ = writeln!(s, "- {}: {}", b.name, b.reason);
        }
        if report.skipped.len() > 20 {
            let _ = writeln!(
                s,
                "- and {} more (all of them in `--json`)",
                report.skipped.len() - 20
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::tests::small_population;

    fn names(k: usize) -> Vec<String> {
        (0..k).map(|i| format!("d{i}")).collect()
    }

    /// A symmetric matrix with unit diagonal from its upper triangle, row
    /// by row.
    fn sym(k: usize, upper: &[f64]) -> Vec<Vec<f64>> {
        let mut m = vec![vec![1.0; k]; k];
        let pairs = (0..k).flat_map(|a| (a + 1..k).map(move |b| (a, b)));
        for ((a, b), &v) in pairs.zip(upper) {
            m[a][b] = v;
            m[b][a] = v;
        }
        m
    }

    #[test]
    fn correlation_summary_of_matrices_with_known_gaps() {
        // Pairs (0,1) (0,2) (0,3) (1,2) (1,3) (2,3); gaps 0, +0.2, +0.3,
        // -0.1, -0.2, undefined.
        let pop = sym(4, &[0.5, 0.3, 0.9, 0.2, 0.4, f64::NAN]);
        let ans = sym(4, &[0.5, 0.1, 0.6, 0.3, 0.6, 0.7]);
        let c = correlation_summary(&names(4), &pop, &ans, 0.15, 3);
        assert_eq!((c.n_pairs, c.n_undefined, c.n_within), (5, 1, 2));
        assert!((c.max_abs_diff.unwrap() - 0.3).abs() < 1e-12);
        assert!((c.mean_abs_diff.unwrap() - 0.16).abs() < 1e-12);
        let worst: Vec<(&str, &str, f64)> = c
            .worst
            .iter()
            .map(|p| (p.a.as_str(), p.b.as_str(), p.diff()))
            .collect();
        // Largest first; the two 0.2 gaps in set order; signs kept.
        assert_eq!(worst.len(), 3);
        assert_eq!((worst[0].0, worst[0].1), ("d0", "d3"));
        assert_eq!((worst[1].0, worst[1].1), ("d0", "d2"));
        assert_eq!((worst[2].0, worst[2].1), ("d1", "d3"));
        assert!((worst[0].2 - 0.3).abs() < 1e-12 && (worst[2].2 + 0.2).abs() < 1e-12);
        // Identical matrices: every pair within, no gap.
        let same = correlation_summary(&names(4), &ans, &ans, 0.15, 10);
        assert_eq!((same.n_pairs, same.n_within, same.worst.len()), (6, 6, 6));
        assert_eq!(same.max_abs_diff, Some(0.0));
        // One dimension: no pairs, no made-up figures.
        let one = correlation_summary(&names(1), &[vec![1.0]], &[vec![1.0]], 0.15, 10);
        assert_eq!(
            (one.n_pairs, one.max_abs_diff, one.mean_abs_diff),
            (0, None, None)
        );
    }

    fn dim(name: &str, tolerance_mm: f64, cannot_follow: bool) -> Dimension {
        Dimension {
            name: name.into(),
            column: name.into(),
            tolerance_mm,
            fitted: false,
            cannot_follow,
        }
    }

    /// A body whose mesh misses its subject by `err_mm` per dimension.
    fn body(name: &str, err_mm: [f64; 3], fitted: [bool; 3]) -> IsoBody {
        let real_m = vec![1.700, 0.950, 0.300];
        IsoBody {
            name: name.into(),
            subject: 10027,
            measured_m: real_m
                .iter()
                .zip(err_mm)
                .map(|(r, e)| r + e / 1000.0)
                .collect(),
            real_m,
            fitted: fitted.to_vec(),
        }
    }

    #[test]
    fn iso_counts_on_a_synthetic_population() {
        // Height 4 mm, girth 9 mm, a breadth (4 mm) a mesh cannot follow.
        let dims = [
            dim("height", 4.0, false),
            dim("girth", 9.0, false),
            dim("breadth", 4.0, true),
        ];
        let both = [true, true, false];
        let bodies = [
            // Within everywhere.
            body("a", [1.0, -8.0, 3.0], both),
            // A fitted girth 10 mm off.
            body("b", [3.0, 10.0, 1.0], both),
            // Only the unfollowable breadth off.
            body("c", [0.0, 0.0, -20.0], both),
            // Height off, but this body's fit did not target it.
            body("d", [-5.0, 0.0, 0.0], [false, true, false]),
        ];
        let iso = judge_iso(&dims, &bodies);
        assert_eq!(iso.n_judged, 4);
        assert_eq!(iso.within, vec![3, 3, 3]);
        assert_eq!(iso.within_all_fitted, 3, "a, c, d");
        assert_eq!(iso.within_all_followable, Some(2), "a, c");
        assert_eq!(iso.within_all, 1, "a");
        let err = iso.mean_abs_error_mm[0].unwrap();
        assert!((err - 2.25).abs() < 1e-9, "{err}");
        assert_eq!(iso.bodies[1].outside, vec!["girth".to_string()]);
        assert_eq!(iso.bodies[1].outside_fitted, 1);
        assert_eq!(iso.bodies[3].outside, vec!["height".to_string()]);
        assert_eq!(iso.bodies[3].outside_fitted, 0);
        // Without a dimension marked unfollowable there is no such count,
        // and nobody judged gives no mean error.
        let plain = [dim("height", 4.0, false)];
        let none = judge_iso(&plain, &[]);
        assert_eq!(none.within_all_followable, None);
        assert_eq!(none.mean_abs_error_mm, vec![None]);
    }

    #[test]
    fn every_dimension_of_a_small_population() {
        let mut d = small_population(8, 11);
        let ansur_set = MeasurementSet::builtin("ansur").unwrap();
        let k = ansur_set
            .definitions
            .iter()
            .filter(|d| d.ansur.is_some())
            .count();
        let r = dimension_statistics(&d, &["chestbreadth"]).unwrap();
        assert_eq!(r.dimensions.len(), k);
        assert_eq!(r.fit_scope, Some(FitScope::Twelve));
        // The twelve fitted dimensions are marked, and only they.
        let fitted: Vec<&str> = r
            .dimensions
            .iter()
            .filter(|d| d.fitted)
            .map(|d| d.column.as_str())
            .collect();
        let mut twelve: Vec<&str> = crate::FIT_TARGETS.iter().map(|(c, _)| *c).collect();
        twelve.sort();
        let mut sorted = fitted.clone();
        sorted.sort();
        assert_eq!(sorted, twelve);
        let marked: Vec<&str> = r
            .dimensions
            .iter()
            .filter(|d| d.cannot_follow)
            .map(|d| d.name.as_str())
            .collect();
        assert_eq!(marked, vec!["chestbreadth"]);
        // In-memory meshes are the fitted ones: measured = achieved.
        assert_eq!(r.record_gaps.len(), crate::FIT_TARGETS.len());
        for g in &r.record_gaps {
            assert_eq!((g.n_bodies, g.n_over), (8, 0), "{g:?}");
            assert!(g.max_mm < 1e-6, "{g:?}");
        }
        assert!(r.skipped.is_empty(), "{:?}", r.skipped);
        assert_eq!(r.sexes.len(), 2, "seed 11 gives 4 bodies of each sex");
        let n: usize = r.sexes.iter().map(|s| s.n_bodies).sum();
        assert_eq!(n, 8 - count_small_sexes(&r, &d));
        let stature = r
            .dimensions
            .iter()
            .position(|d| d.name == "stature")
            .unwrap();
        for st in &r.sexes {
            assert_eq!(st.iso.n_judged, st.n_bodies);
            assert_eq!(st.corr.len(), k);
            assert_eq!(st.correlation.n_pairs, k * (k - 1) / 2);
            let f = st.correlation_followable.as_ref().unwrap();
            assert_eq!(f.n_pairs, (k - 1) * (k - 2) / 2);
            assert!(f
                .worst
                .iter()
                .all(|p| p.a != "chestbreadth" && p.b != "chestbreadth"));
            // ANSUR II in millimetres: the train split's men average 1756 mm.
            if st.sex == Sex::Male {
                assert!((st.ansur_mean_mm[stature] - 1755.7).abs() < 1.0);
            }
            // The ISO judgement agrees with the fit records on every fitted
            // dimension.
            for b in &st.iso.bodies {
                let rec = d.header.bodies.iter().find(|x| x.name == b.name).unwrap();
                let fit = rec.fit.as_ref().unwrap();
                let expect_out: Vec<&str> = r
                    .dimensions
                    .iter()
                    .filter(|dm| {
                        fit.target_mm.get(&dm.column).is_some_and(|t| {
                            (fit.achieved_mm[&dm.column] - t).abs() > dm.tolerance_mm
                        })
                    })
                    .map(|dm| dm.name.as_str())
                    .collect();
                let got_out: Vec<&str> = b
                    .outside
                    .iter()
                    .filter(|o| r.dimensions.iter().any(|dm| &dm.name == *o && dm.fitted))
                    .map(String::as_str)
                    .collect();
                assert_eq!(got_out, expect_out, "{}", b.name);
                assert_eq!(b.outside_fitted, expect_out.len());
            }
        }
        // JSON round trip, and its shape.
        let json = serde_json::to_string(&r).unwrap();
        let back: DimensionReport = serde_json::from_str(&json).unwrap();
        assert_eq!(back, r);
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert_eq!(v["dimensions"].as_array().unwrap().len(), k);
        assert_eq!(v["sexes"][0]["ansur_corr"][0].as_array().unwrap().len(), k);
        assert!(v["sexes"][0]["iso"]["within_all_fitted"].is_u64());
        // Markdown: one row per dimension per sex.
        let md = dimension_markdown(&r);
        assert_eq!(md.matches("\n| stature |").count(), r.sexes.len(), "{md}");
        assert!(md.contains("| chestbreadth * |"), "{md}");

        // A fit record that does not measure as its mesh is pointed out.
        let mut shifted = d.clone();
        let fit = shifted.header.bodies[2].fit.as_mut().unwrap();
        *fit.achieved_mm.get_mut("stature").unwrap() += 5.0;
        let rs = dimension_statistics(&shifted, &[]).unwrap();
        let g = rs
            .record_gaps
            .iter()
            .find(|g| g.dimension == "stature")
            .unwrap();
        assert_eq!((g.n_over, g.worst_body.as_str()), (1, "body-0002"));
        assert!((g.max_mm - 5.0).abs() < 1e-6, "{g:?}");
        assert!(
            dimension_markdown(&rs).contains("stature on 1 of 8 bodies"),
            "{}",
            dimension_markdown(&rs)
        );

        // A body whose subject is not in ANSUR II is noted and left out of
        // the comparison with subjects only.
        let sex0 = d.header.bodies[0].sex.unwrap();
        d.header.bodies[0].ansur_subject = Some(4_000_000);
        let r2 = dimension_statistics(&d, &[]).unwrap();
        assert_eq!(r2.skipped.len(), 1);
        assert!(!r2.skipped[0].everywhere);
        assert!(r2.skipped[0].reason.contains("4000000"), "{:?}", r2.skipped);
        let st2 = r2.sexes.iter().find(|s| s.sex == sex0).unwrap();
        assert_eq!(st2.iso.n_judged + 1, st2.n_bodies);
        assert!(r2.dimensions.iter().all(|d| !d.cannot_follow));
        assert!(r2.sexes.iter().all(|s| s.correlation_followable.is_none()));
        assert!(dimension_markdown(&r2).contains("not in the embedded ANSUR II"));

        // A body without a sex is left out of everything, with a note.
        let mut sexless = d.clone();
        sexless.header.bodies[1].sex = None;
        let r3 = dimension_statistics(&sexless, &[]).unwrap();
        assert_eq!(r3.sexes.iter().map(|s| s.n_bodies).sum::<usize>(), 7);
        assert!(r3
            .skipped
            .iter()
            .any(|b| b.name == "body-0001" && b.everywhere));

        // Bad parameters and foreign datasets are errors that say so.
        let e = dimension_statistics(&d, &["chestbreath"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("chestbreath"), "{e}");
        let mut tiny = d.clone();
        tiny.topology =
            std::sync::Arc::new(tapeshape_mesh::Topology::new(3, vec![[0, 1, 2]]).unwrap());
        let e = dimension_statistics(&tiny, &[]).unwrap_err().to_string();
        assert!(e.contains("template topology"), "{e}");
        let mut short = d.clone();
        short.bodies.pop();
        let e = dimension_statistics(&short, &[]).unwrap_err().to_string();
        assert!(e.contains("8 body records but 7 meshes"), "{e}");
    }

    /// Bodies of a sex with fewer than three (left out of the blocks).
    fn count_small_sexes(r: &DimensionReport, d: &Dataset) -> usize {
        [Sex::Male, Sex::Female]
            .iter()
            .filter(|s| !r.sexes.iter().any(|st| st.sex == **s))
            .map(|s| d.header.bodies.iter().filter(|b| b.sex == Some(*s)).count())
            .sum()
    }
}
