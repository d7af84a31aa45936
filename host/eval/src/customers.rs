//! Real customers through the product's own path: every ANSUR II test-split
//! person (ids divisible by 4, never used to train, fit or calibrate)
//! entered into the station's estimator (the embedded default model and
//! its default settings, as `tapeshape predict` runs them), with their real
//! values of an input set (`quick` or `ansur`) and, optionally, their sex.
//!
//! What is measured, per person:
//!
//! * every other `ansur` dimension (one whose ANSUR II column the input set
//!   does not give) measured on the predicted body and compared with the
//!   person's real value, beside ordinary least squares from the same input
//!   columns fitted on the ANSUR II train split, pooled and with sex (a
//!   male indicator), in the same run;
//! * the entered values re-measured on the body and judged against their
//!   ISO 20685-1 allowable error (the definition's tolerance class);
//! * refusals (with the estimator's message), flipped and collapsed
//!   triangles.
//!
//! The measurements on the body use the same definitions the model was
//! trained with (the union of the `ansur` and `quick` sets), compiled once.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use tapeshape_estimator::priors::CANNOT_FOLLOW_ANSUR;
use tapeshape_estimator::{Estimator, Inputs, PredictOptions};
use tapeshape_measure::{CompiledSet, MeasurementSet};
use tapeshape_population::ansur::{Ansur, Sex, Split, Subject};

use crate::experiments::EvalError;
use crate::surface::{SurfaceCheck, SurfaceVerdict};

/// What to run.
#[derive(Debug, Clone)]
pub struct CustomersOptions {
    /// The input set: `quick` or `ansur` (its measurements with an ANSUR
    /// column are entered).
    pub input_set: String,
    /// Give the estimator the person's sex.
    pub with_sex: bool,
    /// At most this many people per sex (the first by id), `None`: all.
    pub per_sex: Option<usize>,
    /// ANSUR columns left out of the input (e.g. flexed girths).
    pub leave_out: Vec<String>,
    /// Enter the values as survey values taken as ANSUR II takes them
    /// ([`tapeshape_estimator::Inputs::ansur_survey`]): readings the
    /// standing mesh cannot take that way are recorded, not fitted.
    pub ansur_survey: bool,
    /// The estimator's options (default: the station's).
    pub options: PredictOptions,
}

/// What [`CustomersRun::iso_pass`] puts after the name of a reading that
/// was recorded, not fitted.
pub const RECORDED_SUFFIX: &str = " (recorded, not fitted)";

/// A person missing this many fitted readings or more is listed by name on
/// the page ([`markdown`]).
pub const MANY_MISSES: usize = 5;

/// One person's outcome.
#[derive(Debug, Clone)]
pub struct PersonResult {
    /// ANSUR II subject id.
    pub id: u32,
    /// Sex.
    pub sex: Sex,
    /// The estimator's message when it refused.
    pub refused: Option<String>,
    /// Every measurement of the union set on the body, metres (empty when refused).
    pub body: Vec<f64>,
    /// Per entered reading: (index in the union set, entered m, within ISO).
    pub entered: Vec<(usize, f64, bool)>,
    /// Union-set indices of the entered readings the estimator recorded but
    /// did not fit (the report's `recorded_only`: ANSUR II dimensions the
    /// standing mesh cannot take as ANSUR does).
    pub recorded_only: Vec<usize>,
    /// Flipped triangles of the result.
    pub flipped: usize,
    /// Collapsed triangles of the result (area below 1 % of the step-1
    /// shape's).
    pub collapsed: usize,
    /// The estimate's warnings.
    pub warnings: Vec<String>,
    /// The soft targets' conditional SDs (name, mm): the body's spread where
    /// nothing was measured.
    pub soft_sd_mm: Vec<(String, f64)>,
    /// The surface check's verdict on the body ([`run_with_surface`];
    /// `None` when not asked for or refused).
    pub surface: Option<SurfaceVerdict>,
}

impl PersonResult {
    /// A person with nothing estimated yet: not refused, no body, no
    /// readings, no warnings, no surface verdict.
    pub fn new(id: u32, sex: Sex) -> Self {
        Self {
            id,
            sex,
            refused: None,
            body: Vec::new(),
            entered: Vec::new(),
            recorded_only: Vec::new(),
            flipped: 0,
            collapsed: 0,
            warnings: Vec::new(),
            soft_sd_mm: Vec::new(),
            surface: None,
        }
    }
}

/// One held-out dimension's errors, mm.
#[derive(Debug, Clone)]
pub struct DimRow {
    /// ANSUR II column.
    pub column: String,
    /// Mean absolute error of the body's value.
    pub body: f64,
    /// Mean signed error of the body's value (body - real).
    pub body_bias: f64,
    /// Least squares with sex.
    pub ols_sex: f64,
    /// Least squares, sexes pooled.
    pub ols_pooled: f64,
}

/// The whole run.
#[derive(Debug, Clone)]
pub struct CustomersRun {
    /// Per person.
    pub people: Vec<PersonResult>,
    /// Per held-out dimension.
    pub dims: Vec<DimRow>,
    /// The union set's names, in order.
    pub names: Vec<String>,
    /// ISO tolerance per union-set measurement, mm.
    pub tolerance_mm: Vec<f64>,
    /// Train-split subjects the regressions were fitted on.
    pub n_train: usize,
    /// Seconds the predictions took (wall).
    pub seconds: f64,
}

/// Mean absolute errors over the held-out dimensions the standing mesh can
/// measure as ANSUR II defines them ([`CustomersRun::overall_followable`]).
#[derive(Debug, Clone, PartialEq)]
pub struct FollowableSummary {
    /// How many such dimensions were held out (at least 1).
    pub count: usize,
    /// The body's mean absolute error over them, mm.
    pub body_mm: f64,
    /// Least squares with sex, mean absolute error over them, mm.
    pub ols_sex_mm: f64,
    /// The largest per-dimension ratio body / least squares with sex.
    pub worst_ratio: f64,
    /// The ANSUR II column of that ratio.
    pub worst_column: String,
}

impl FollowableSummary {
    /// Body MAE over least-squares-with-sex MAE (issue 12's target: at most 1.10).
    pub fn ratio(&self) -> f64 {
        self.body_mm / self.ols_sex_mm
    }
}

impl CustomersRun {
    /// Mean over the held-out dimensions of (body, ols with sex, pooled), mm.
    pub fn overall(&self) -> (f64, f64, f64) {
        let n = self.dims.len().max(1) as f64;
        (
            self.dims.iter().map(|d| d.body).sum::<f64>() / n,
            self.dims.iter().map(|d| d.ols_sex).sum::<f64>() / n,
            self.dims.iter().map(|d| d.ols_pooled).sum::<f64>() / n,
        )
    }

    /// The held-out dimensions the standing A-pose mesh can measure as
    /// ANSUR II defines them: all but [`CANNOT_FOLLOW_ANSUR`] (flexed
    /// girths, calipers that compress the tissue). Issue 12's item 1 leaves
    /// those out of the checks rather than compare a different quantity
    /// under the same name; the page shows them all the same.
    pub fn followable(&self) -> impl Iterator<Item = &DimRow> {
        self.dims
            .iter()
            .filter(|d| !CANNOT_FOLLOW_ANSUR.contains(&d.column.as_str()))
    }

    /// The summary over [`CustomersRun::followable`]; `None` when the run
    /// holds out none of them.
    pub fn overall_followable(&self) -> Option<FollowableSummary> {
        let rows: Vec<&DimRow> = self.followable().collect();
        let worst = rows
            .iter()
            .max_by(|a, b| (a.body / a.ols_sex).total_cmp(&(b.body / b.ols_sex)))?;
        let n = rows.len() as f64;
        Some(FollowableSummary {
            count: rows.len(),
            body_mm: rows.iter().map(|d| d.body).sum::<f64>() / n,
            ols_sex_mm: rows.iter().map(|d| d.ols_sex).sum::<f64>() / n,
            worst_ratio: worst.body / worst.ols_sex,
            worst_column: worst.column.clone(),
        })
    }

    /// The surface check over the people estimated with a verdict, with
    /// the `n_worst` largest shares; `None` when nobody was checked.
    pub fn surface_summary(&self, n_worst: usize) -> Option<SurfaceSummary> {
        let mut judged: Vec<(u32, Sex, SurfaceVerdict)> = self
            .people
            .iter()
            .filter_map(|p| Some((p.id, p.sex, p.surface?)))
            .collect();
        if judged.is_empty() {
            return None;
        }
        let shares: Vec<f64> = judged.iter().map(|(_, _, v)| v.excess.share()).collect();
        let worst: Vec<f64> = judged.iter().map(|(_, _, v)| v.excess.worst).collect();
        let q = |v: &[f64]| [0.5, 0.99, 1.0].map(|q| crate::surface::quantile(v, q));
        let summary = SurfaceSummary {
            checked: judged.len(),
            passed: judged.iter().filter(|(_, _, v)| v.pass).count(),
            share: q(&shares),
            worst: q(&worst),
            worst_people: Vec::new(),
        };
        judged.sort_by(|a, b| {
            b.2.excess
                .share()
                .total_cmp(&a.2.excess.share())
                .then(a.0.cmp(&b.0))
        });
        judged.truncate(n_worst);
        Some(SurfaceSummary {
            worst_people: judged,
            ..summary
        })
    }

    /// People refused.
    pub fn refused(&self) -> usize {
        self.people.iter().filter(|p| p.refused.is_some()).count()
    }

    /// Share of entered readings (over all people estimated) within their
    /// ISO 20685-1 allowable error on the body, and per measurement name
    /// (share, count). Readings the estimator recorded but did not fit
    /// ([`PersonResult::recorded_only`]) are left out of the share (issue
    /// 12, item 1: out of the checks) and listed per name with
    /// [`RECORDED_SUFFIX`] after it.
    pub fn iso_pass(&self) -> (f64, BTreeMap<String, (f64, usize)>) {
        let mut per: BTreeMap<String, (usize, usize)> = BTreeMap::new();
        let (mut ok, mut all) = (0usize, 0usize);
        for p in self.people.iter().filter(|p| p.refused.is_none()) {
            for &(j, _, pass) in &p.entered {
                let recorded = p.recorded_only.contains(&j);
                let name = if recorded {
                    format!("{}{RECORDED_SUFFIX}", self.names[j])
                } else {
                    self.names[j].clone()
                };
                let e = per.entry(name).or_default();
                e.1 += 1;
                e.0 += usize::from(pass);
                if !recorded {
                    all += 1;
                    ok += usize::from(pass);
                }
            }
        }
        (
            ok as f64 / all.max(1) as f64,
            per.into_iter()
                .map(|(k, (o, a))| (k, (o as f64 / a.max(1) as f64, a)))
                .collect(),
        )
    }
}

/// The surface check over a run ([`CustomersRun::surface_summary`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceSummary {
    /// Bodies checked (people estimated, with a verdict).
    pub checked: usize,
    /// Bodies that pass.
    pub passed: usize,
    /// Share of edges beyond envelope + margin: median, 99th percentile,
    /// largest over the bodies (0..=1).
    pub share: [f64; 3],
    /// Worst excess angle (fold - envelope): median, 99th percentile,
    /// largest over the bodies, radians.
    pub worst: [f64; 3],
    /// The bodies with the largest share, largest first: (id, sex, verdict).
    pub worst_people: Vec<(u32, Sex, SurfaceVerdict)>,
}

/// `name` where it names a measurement set [`MeasurementSet::load`] takes
/// (a built-in set or a set file), else its error in words: the example
/// programs' `--set` value parser.
pub fn known_set(name: &str) -> Result<String, String> {
    MeasurementSet::load(name)
        .map(|_| name.to_string())
        .map_err(|e| e.to_string())
}

/// Ordinary least squares with an intercept: `x` is n x k (one row per
/// subject), `y` n; returns the k coefficients then the intercept.
pub fn ols(x: &DMatrix<f64>, y: &DVector<f64>) -> Option<DVector<f64>> {
    // Columns of x plus an intercept, solved by SVD (well conditioned
    // enough for a handful of body dimensions in metres).
    let n = x.nrows();
    let mut a = DMatrix::from_element(n, x.ncols() + 1, 1.0);
    a.view_mut((0, 0), (n, x.ncols())).copy_from(x);
    a.svd(true, true).solve(y, 1e-12).ok()
}

/// A subject's values (metres) of `cols`, then 1 for a man / 0 for a woman
/// when `with_sex`; `None` if a column is missing.
pub fn features(s: &Subject, cols: &[String], with_sex: bool) -> Option<Vec<f64>> {
    let mut v: Vec<f64> = cols.iter().map(|c| s.dim(c)).collect::<Option<_>>()?;
    if with_sex {
        v.push(if s.sex == Sex::Male { 1.0 } else { 0.0 });
    }
    Some(v)
}

/// The value `b` (from [`ols`]) predicts for `x`.
pub fn predict_row(b: &DVector<f64>, x: &[f64]) -> f64 {
    x.iter().zip(b.iter()).map(|(a, c)| a * c).sum::<f64>() + b[b.len() - 1]
}

/// The test-split people: all, or the first `per_sex` of each sex by id.
pub fn test_people(ansur: &Ansur, per_sex: Option<usize>) -> Vec<&Subject> {
    let mut v = Vec::new();
    for sex in [Sex::Male, Sex::Female] {
        let mut s: Vec<&Subject> = ansur.subjects(Some(sex), Split::Test).collect();
        s.sort_by_key(|s| s.id);
        if let Some(k) = per_sex {
            s.truncate(k);
        }
        v.extend(s);
    }
    debug_assert!(v.iter().all(|s| s.id % 4 == 0));
    v
}

/// The readings `opts` enters: (measurement name, ANSUR II column) of the
/// input set's measurements that have an ANSUR column, are known to
/// `estimator` and are not left out.
pub fn entered_readings(
    estimator: &Estimator,
    opts: &CustomersOptions,
) -> Result<Vec<(String, String)>, EvalError> {
    let input = MeasurementSet::load(&opts.input_set)?;
    Ok(input
        .definitions
        .iter()
        .filter_map(|d| d.ansur.clone().map(|c| (d.name.clone(), c)))
        .filter(|(n, c)| estimator.set().index_of(n).is_some() && !opts.leave_out.contains(c))
        .collect())
}

/// The estimator inputs of subject `s`: its real values (metres) of the
/// `entered` readings ([`entered_readings`]) it has, and its sex when
/// `with_sex`.
pub fn inputs_of(s: &Subject, entered: &[(String, String)], with_sex: bool) -> Inputs {
    let mut inputs = Inputs::new();
    for (name, col) in entered {
        if let Some(v) = s.dim(col) {
            // Names are unique in the set: insert cannot fail.
            let _ = inputs.insert_metres(name, v);
        }
    }
    if with_sex {
        inputs.sex = Some(s.sex);
    }
    inputs
}

/// The `ansur` and `quick` sets as one set, and compiled on `estimator`'s
/// template: what every body of a run is measured with.
pub fn measuring_set(estimator: &Estimator) -> Result<(MeasurementSet, CompiledSet), EvalError> {
    let text = tapeshape_estimator::union_set_text(&["ansur", "quick"])
        .map_err(|e| EvalError::Data(e.to_string()))?;
    let union = MeasurementSet::from_toml_str(&text, "ansur+quick")?;
    let compiled = union.compile(estimator.topology(), &tapeshape_body::anatomy::anatomy())?;
    Ok((union, compiled))
}

/// Whether `measured` (metres, member `j` of `union`) meets the real value
/// `real` (metres) within the member's ISO 20685-1 allowable error.
pub fn within_iso(union: &MeasurementSet, j: usize, measured: f64, real: f64) -> bool {
    (measured - real).abs() <= union.definitions[j].tolerance.mm() / 1000.0
}

/// `options` with step 2's soft pull
/// (`tapeshape_model::Step2Settings::soft_pull`) set to `pull` and the
/// station's real-people soft targets kept on, as the examples'
/// `--soft-pull SHARE` asks. Errors for a share outside `[0, 1]` (else
/// every person would be refused one by one).
pub fn with_soft_pull(
    options: &PredictOptions,
    pull: f64,
) -> Result<PredictOptions, tapeshape_estimator::PredictError> {
    let mut settings = options.settings();
    settings.step2.soft_pull = pull;
    let options = PredictOptions {
        real_people: Some(options.real_people()),
        pipeline: tapeshape_estimator::Pipeline::Custom(Box::new(settings)),
        ..options.clone()
    };
    options.resolve()?;
    Ok(options)
}

/// Runs every test-split person through `estimator` (see the module docs).
pub fn run(estimator: &Estimator, opts: &CustomersOptions) -> Result<CustomersRun, EvalError> {
    run_with_surface(estimator, opts, None)
}

/// [`run`], and when `surface` is given, the surface check of every body
/// (done as each body is estimated, so meshes are not kept). Errors when
/// the check's envelope is of another template than the estimator's.
pub fn run_with_surface(
    estimator: &Estimator,
    opts: &CustomersOptions,
    surface: Option<&SurfaceCheck>,
) -> Result<CustomersRun, EvalError> {
    let data = |e: &dyn std::fmt::Display| EvalError::Data(e.to_string());
    if let Some(check) = surface {
        check
            .envelope
            .check_topology(estimator.topology())
            .map_err(|e| data(&e))?;
    }
    let (union, compiled) = measuring_set(estimator)?;
    let entered = entered_readings(estimator, opts)?;
    let in_cols: Vec<String> = entered.iter().map(|(_, c)| c.clone()).collect();
    let ansur_set = MeasurementSet::load("ansur")?;
    let held: Vec<(usize, String)> = ansur_set
        .definitions
        .iter()
        .filter_map(|d| {
            let c = d.ansur.clone()?;
            (!in_cols.contains(&c)).then_some((union.index_of(&d.name)?, c))
        })
        .collect();
    let ansur = Ansur::get()?;
    let people = test_people(ansur, opts.per_sex);
    let t0 = std::time::Instant::now();
    let options = opts.options.clone();
    let results: Vec<PersonResult> = people
        .par_iter()
        .map(|s| {
            let mut inputs = inputs_of(s, &entered, opts.with_sex);
            inputs.ansur_survey = opts.ansur_survey;
            let idx: Vec<(usize, f64)> = entered
                .iter()
                .filter_map(|(name, col)| {
                    Some((union.index_of(name).unwrap_or(usize::MAX), s.dim(col)?))
                })
                .collect();
            let mut r = PersonResult::new(s.id, s.sex);
            match estimator.predict(&inputs, &options) {
                Err(e) => r.refused = Some(e.to_string()),
                Ok(est) => match compiled.measure(&est.mesh.vertices) {
                    Err(e) => r.refused = Some(format!("measuring the body: {e}")),
                    Ok(m) => {
                        r.body = m.iter().map(|m| m.value).collect();
                        r.entered = idx
                            .iter()
                            .filter(|(j, _)| *j < r.body.len())
                            .map(|&(j, v)| (j, v, within_iso(&union, j, r.body[j], v)))
                            .collect();
                        r.recorded_only = est
                            .report
                            .prediction
                            .measurements
                            .iter()
                            .filter(|m| m.recorded_only)
                            .filter_map(|m| union.index_of(&m.name))
                            .collect();
                        r.flipped = est.report.prediction.plausibility.flipped_triangles;
                        r.collapsed = est.report.prediction.plausibility.degenerate_triangles;
                        // The topology was checked above: judging cannot fail.
                        r.surface = surface.and_then(|c| c.judge(&est.mesh.vertices).ok());
                        r.soft_sd_mm = est
                            .report
                            .soft_targets
                            .iter()
                            .map(|t| (t.name.clone(), t.sd_mm))
                            .collect();
                        r.warnings = est
                            .report
                            .warnings
                            .iter()
                            .map(ToString::to_string)
                            .collect();
                    }
                },
            }
            r
        })
        .collect();
    let seconds = t0.elapsed().as_secs_f64();
    // Regressions on the train split, from the same input columns.
    let train: Vec<&Subject> = ansur
        .subjects(None, Split::Train)
        .filter(|s| features(s, &in_cols, false).is_some())
        .collect();
    let mut dims = Vec::new();
    for (j, col) in &held {
        let rows: Vec<&&Subject> = train.iter().filter(|s| s.dim(col).is_some()).collect();
        let y = DVector::from_iterator(rows.len(), rows.iter().filter_map(|s| s.dim(col)));
        let fit = |with_sex: bool| {
            let k = in_cols.len() + usize::from(with_sex);
            let x = DMatrix::from_row_iterator(
                rows.len(),
                k,
                rows.iter()
                    .flat_map(|s| features(s, &in_cols, with_sex).unwrap_or_default()),
            );
            ols(&x, &y)
        };
        let (bs, bp) = (fit(true), fit(false));
        let (mut e_body, mut e_s, mut e_p, mut n) = (0.0, 0.0, 0.0, 0usize);
        let mut bias = 0.0;
        for (p, s) in results.iter().zip(&people) {
            let (Some(v), None) = (s.dim(col), &p.refused) else {
                continue;
            };
            let (Some(fs), Some(fp)) = (features(s, &in_cols, true), features(s, &in_cols, false))
            else {
                continue;
            };
            e_body += (p.body[*j] - v).abs();
            bias += p.body[*j] - v;
            e_s += bs
                .as_ref()
                .map_or(f64::NAN, |b| (predict_row(b, &fs) - v).abs());
            e_p += bp
                .as_ref()
                .map_or(f64::NAN, |b| (predict_row(b, &fp) - v).abs());
            n += 1;
        }
        let k = 1000.0 / n.max(1) as f64;
        dims.push(DimRow {
            column: col.clone(),
            body: e_body * k,
            body_bias: bias * k,
            ols_sex: e_s * k,
            ols_pooled: e_p * k,
        });
    }
    Ok(CustomersRun {
        people: results,
        dims,
        names: union.definitions.iter().map(|d| d.name.clone()).collect(),
        tolerance_mm: union.definitions.iter().map(|d| d.tolerance.mm()).collect(),
        n_train: train.len(),
        seconds,
    })
}

/// A Markdown page of `run` (tables of the held-out dimensions, ISO pass
/// shares, refusals).
pub fn markdown(run: &CustomersRun, opts: &CustomersOptions, command: &str) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let (b, os, op) = run.overall();
    let (iso, per) = run.iso_pass();
    let n = run.people.len();
    let _ = writeln!(
        s,
        "# Real customers: ANSUR II test split through the estimator ({} input{})\n",
        opts.input_set,
        if opts.with_sex { ", with sex" } else { "" }
    );
    let _ = writeln!(s, "Command: `{command}`\n");
    let _ = writeln!(
        s,
        "{n} test-split people (ids divisible by 4), {} refused; predictions {:.1} s wall. \
Regressions fitted on {} ANSUR II train-split subjects.\n",
        run.refused(),
        run.seconds,
        run.n_train
    );
    if run.dims.is_empty() {
        let _ = writeln!(
            s,
            "The input gives every `ansur` dimension: none is held out."
        );
    } else {
        let _ = writeln!(
            s,
            "| | mean absolute error over the {} other `ansur` dimensions, mm |\n|---|---|",
            run.dims.len()
        );
        let _ = writeln!(s, "| body (estimator) | **{b:.2}** |");
        let _ = writeln!(s, "| least squares with sex | {os:.2} |");
        let _ = writeln!(s, "| least squares, pooled | {op:.2} |");
        let _ = writeln!(s, "| ratio body / with sex | {:.3} |\n", b / os);
        match run.overall_followable() {
            None => {
                let _ = writeln!(
                    s,
                    "None of them is one the standing mesh can measure as ANSUR II defines it.\n"
                );
            }
            Some(f) => {
                let _ = writeln!(
                    s,
                    "Over the {} of them the standing mesh can measure as ANSUR II defines them \
(all but {}: flexed girths and calipers that compress the tissue, \
docs/measurements.md): body **{:.2}** mm, least squares with sex {:.2} mm, \
ratio **{:.3}**; the worst of them {} at {:.2} x.\n",
                    f.count,
                    CANNOT_FOLLOW_ANSUR.join(", "),
                    f.body_mm,
                    f.ols_sex_mm,
                    f.ratio(),
                    f.worst_column,
                    f.worst_ratio
                );
            }
        }
        let _ = writeln!(
            s,
            "| dimension | body mm | body bias mm | LS with sex mm | LS pooled mm | ratio |\n|---|---|---|---|---|---|"
        );
        for d in &run.dims {
            let _ = writeln!(
                s,
                "| {} | {:.1} | {:+.1} | {:.1} | {:.1} | {:.2} |",
                d.column,
                d.body,
                d.body_bias,
                d.ols_sex,
                d.ols_pooled,
                d.body / d.ols_sex
            );
        }
    }
    let _ = writeln!(
        s,
        "\nEntered values re-measured on the body within ISO 20685-1: **{:.1} %**{}\n",
        100.0 * iso,
        if per.keys().any(|k| k.ends_with(RECORDED_SUFFIX)) {
            " (the readings marked recorded, not fitted, are left out: the standing mesh \
cannot take them as ANSUR II defines them, or measures them as the sum of other readings \
that ANSUR II takes differently, and the estimator does not fit them; their rows below are \
for information)"
        } else {
            ""
        }
    );
    let _ = writeln!(s, "| measurement | within ISO | readings |\n|---|---|---|");
    for (k, (share, count)) in &per {
        let _ = writeln!(s, "| {k} | {:.1} % | {count} |", 100.0 * share);
    }
    // The people behind a share short of 100 %: one body that misses
    // many readings reads very differently from many bodies missing one.
    let mut missing: Vec<(&PersonResult, Vec<&str>)> = run
        .people
        .iter()
        .map(|p| {
            let misses = p
                .entered
                .iter()
                .filter(|(j, _, ok)| !ok && !p.recorded_only.contains(j))
                .map(|(j, _, _)| run.names[*j].as_str())
                .collect::<Vec<_>>();
            (p, misses)
        })
        .filter(|(_, m)| m.len() >= MANY_MISSES)
        .collect();
    missing.sort_by_key(|(p, m)| (std::cmp::Reverse(m.len()), p.id));
    if !missing.is_empty() {
        let _ = writeln!(
            s,
            "\nPeople with {MANY_MISSES} or more fitted readings outside ISO 20685-1:\n\n\
| subject | sex | readings outside | which | warnings (first clause) |\n|---|---|---|---|---|"
        );
        for (p, m) in &missing {
            let _ = writeln!(
                s,
                "| {} | {:?} | {} | {} | {} |",
                p.id,
                p.sex,
                m.len(),
                m.join(", "),
                // Each warning's first clause (what, not the advice).
                p.warnings
                    .iter()
                    .map(|w| w.split(": ").next().unwrap_or(w))
                    .collect::<Vec<_>>()
                    .join("; ")
                    .replace('|', "/")
            );
        }
    }
    let flipped: usize = run.people.iter().map(|p| p.flipped).sum();
    let collapsed: usize = run.people.iter().map(|p| p.collapsed).sum();
    let _ = writeln!(
        s,
        "\nFlipped triangles over all bodies: {flipped}; collapsed: {collapsed}."
    );
    let mut folded: Vec<&PersonResult> = run
        .people
        .iter()
        .filter(|p| p.flipped + p.collapsed > 0)
        .collect();
    if !folded.is_empty() {
        folded.sort_by_key(|p| std::cmp::Reverse(p.flipped + p.collapsed));
        let most: Vec<String> = folded
            .iter()
            .take(10)
            .map(|p| format!("{} ({})", p.id, p.flipped + p.collapsed))
            .collect();
        let _ = writeln!(
            s,
            "Bodies with a flipped or collapsed triangle: {} of {}; the most: {}.",
            folded.len(),
            run.people.len(),
            most.join(", ")
        );
    }
    let refused: Vec<String> = run
        .people
        .iter()
        .filter_map(|p| p.refused.as_ref().map(|r| format!("- {}: {r}", p.id)))
        .collect();
    if !refused.is_empty() {
        let _ = writeln!(s, "\nRefused:\n\n{}", refused.join("\n"));
    }
    s
}

/// A Markdown section on the surface check of `run` (nothing when nobody
/// was checked): `check` is what it was run with, `training` names its
/// training bodies.
pub fn surface_markdown(run: &CustomersRun, check: &SurfaceCheck, training: &str) -> String {
    use std::fmt::Write as _;
    let Some(sum) = run.surface_summary(10) else {
        return String::new();
    };
    let deg = 180.0 / std::f64::consts::PI;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\n## Surface check\n\nEnvelope: per interior edge ({} edges), the largest fold over the {} \
bodies of {training}. Rule: at most {:.3} % of edges fold more than {:.1} degrees beyond it \
(`host/eval/src/surface.rs`).\n",
        check.envelope.edges().len(),
        check.envelope.bodies(),
        100.0 * check.rule.max_share,
        check.rule.delta * deg
    );
    let _ = writeln!(
        s,
        "**{} of {} bodies pass.**\n\n| | median | 99th percentile | largest |\n|---|---|---|---|",
        sum.passed, sum.checked
    );
    let _ = writeln!(
        s,
        "| share of edges beyond envelope + margin, % | {:.3} | {:.3} | {:.3} |",
        100.0 * sum.share[0],
        100.0 * sum.share[1],
        100.0 * sum.share[2]
    );
    let _ = writeln!(
        s,
        "| worst excess angle, degrees | {:.1} | {:.1} | {:.1} |\n",
        sum.worst[0] * deg,
        sum.worst[1] * deg,
        sum.worst[2] * deg
    );
    let _ = writeln!(
        s,
        "| worst people: id | sex | edges beyond | share % | worst excess deg | verdict |\n|---|---|---|---|---|---|"
    );
    for (id, sex, v) in &sum.worst_people {
        let _ = writeln!(
            s,
            "| {id} | {sex:?} | {} | {:.3} | {:.1} | {} |",
            v.excess.count,
            100.0 * v.excess.share(),
            v.excess.worst * deg,
            if v.pass { "pass" } else { "fail" }
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(column: &str, body: f64, ols_sex: f64) -> DimRow {
        DimRow {
            column: column.into(),
            body,
            body_bias: 0.0,
            ols_sex,
            ols_pooled: ols_sex,
        }
    }

    /// A run with nobody in it and these held-out dimensions.
    fn run_of(dims: Vec<DimRow>) -> CustomersRun {
        CustomersRun {
            people: Vec::new(),
            dims,
            names: Vec::new(),
            tolerance_mm: Vec::new(),
            n_train: 0,
            seconds: 0.0,
        }
    }

    #[test]
    fn followable_leaves_out_exactly_what_the_mesh_cannot_follow() {
        let run = run_of(vec![
            row("stature", 10.0, 10.0),
            row("chestbreadth", 60.0, 10.0),
            row("hipbreadth", 30.0, 6.0),
            row("forearmcircumferenceflexed", 40.0, 8.0),
        ]);
        let f = run.overall_followable().expect("two followable dimensions");
        assert_eq!(f.count, 2, "chest breadth and the flexed forearm are out");
        assert!((f.body_mm - 20.0).abs() < 1e-12 && (f.ols_sex_mm - 8.0).abs() < 1e-12);
        assert!((f.ratio() - 2.5).abs() < 1e-12);
        assert_eq!(f.worst_column, "hipbreadth");
        assert!((f.worst_ratio - 5.0).abs() < 1e-12);
        // The full mean still counts every dimension.
        assert!((run.overall().0 - 35.0).abs() < 1e-12);
    }

    #[test]
    fn surface_summary_counts_passes_and_orders_the_worst() {
        use crate::surface::Excess;
        let person = |id: u32, count: usize, pass: bool| PersonResult {
            surface: Some(SurfaceVerdict {
                excess: Excess {
                    count,
                    edges: 1000,
                    delta: 0.1,
                    worst: count as f64 / 100.0,
                    worst_edge: 0,
                },
                pass,
            }),
            ..PersonResult::new(id, Sex::Female)
        };
        let mut run = run_of(Vec::new());
        assert_eq!(run.surface_summary(3), None);
        run.people = vec![
            person(4, 1, true),
            person(8, 30, false),
            person(12, 2, true),
        ];
        let mut unchecked = person(16, 0, true);
        unchecked.surface = None;
        run.people.push(unchecked);
        let s = run.surface_summary(2).unwrap();
        assert_eq!((s.checked, s.passed), (3, 2));
        assert_eq!(s.share, [0.002, 0.03, 0.03]);
        assert_eq!(s.worst, [0.02, 0.3, 0.3]);
        let ids: Vec<u32> = s.worst_people.iter().map(|p| p.0).collect();
        assert_eq!(ids, vec![8, 12]);
    }

    #[test]
    fn a_run_holding_out_only_what_the_mesh_cannot_follow_says_so() {
        let run = run_of(vec![row("chestbreadth", 60.0, 10.0)]);
        assert_eq!(run.overall_followable(), None);
        let opts = CustomersOptions {
            input_set: "ansur".into(),
            with_sex: true,
            per_sex: None,
            leave_out: vec!["chestbreadth".into()],
            ansur_survey: false,
            options: PredictOptions::default(),
        };
        let page = markdown(&run, &opts, "cmd");
        assert!(page.contains("None of them is one the standing mesh can measure"));
        assert!(!page.contains("NaN"), "{page}");
    }
}
