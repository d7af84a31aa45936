//! The recommendation as text, for the command line (`tapeshape predict
//! --chart`) and logs. Millimetres, as the station's reports.

use std::fmt;

use crate::chart::Role;
use crate::recommend::{
    BetweenReason, GarmentFit, Placement, Position, Recommendation, Side, SizeFit, Source,
};

/// A probability as a person reads it: whole percent, with `<1 %` and
/// `>99 %` rather than a rounded 0 or 100 that is not exactly so.
pub fn percent(p: f64) -> String {
    if p > 0.0 && p < 0.005 {
        "<1 %".to_string()
    } else if (0.995..1.0).contains(&p) {
        ">99 %".to_string()
    } else {
        format!("{:.0} %", 100.0 * p)
    }
}

fn source_text(source: Source) -> String {
    format!("{} ±{:.0} mm", source.word(), source.sd_mm())
}

fn placement_line(f: &mut fmt::Formatter<'_>, label: &str, p: &Placement) -> fmt::Result {
    let amount = match p.position {
        Position::Inside { .. } => String::new(),
        Position::Below { by_mm } => format!(" ({by_mm:.0} mm below)"),
        Position::Above { by_mm } => format!(" ({by_mm:.0} mm above)"),
    };
    writeln!(
        f,
        "  {:<14} {:>6.0} mm  {:<18} {:<26} {}{amount}",
        p.dimension,
        p.value_mm,
        source_text(p.source),
        format!("{label} {}", p.interval),
        p.words
    )
}

fn misfits(size: &SizeFit) -> String {
    let words: Vec<String> = size
        .placements
        .iter()
        .filter(|p| p.role == Role::Primary && !p.position.is_inside())
        .map(|p| p.words.clone())
        .collect();
    format!("{} is {}", size.label, words.join(" and "))
}

impl fmt::Display for GarmentFit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Some(best) = &self.best else {
            let names: Vec<&str> = self
                .missing
                .iter()
                .filter(|m| m.role == Role::Primary)
                .map(|m| m.dimension.as_str())
                .collect();
            return writeln!(
                f,
                "{}: no size: {} neither measured nor estimated",
                self.garment,
                names.join(", ")
            );
        };
        writeln!(
            f,
            "{}: {} ({})",
            self.garment,
            best.label,
            percent(best.probability)
        )?;
        if let Some(between) = &self.between {
            let other = &between.other;
            match &between.reason {
                BetweenReason::NoSizeHoldsAll => writeln!(
                    f,
                    "  between {} and {} ({}): no size holds every reading; {}, {}",
                    best.label,
                    other.label,
                    percent(other.probability),
                    misfits(best),
                    misfits(other)
                )?,
                BetweenReason::NearEdge {
                    dimension,
                    value_mm,
                    edge_mm,
                    distance_mm,
                    source,
                } => writeln!(
                    f,
                    "  between {} and {} ({}): {dimension} {value_mm:.0} mm ({}) is {distance_mm:.0} mm {} the edge of {} at {edge_mm:.0} mm",
                    best.label,
                    other.label,
                    percent(other.probability),
                    source_text(*source),
                    if value_mm < edge_mm { "below" } else { "above" },
                    best.label,
                )?,
            }
        }
        for b in &self.beyond {
            writeln!(
                f,
                "  beyond the chart: {} {:.0} mm {} every size",
                b.dimension,
                b.by_mm,
                match b.side {
                    Side::Below => "below",
                    Side::Above => "above",
                }
            )?;
        }
        for p in &best.placements {
            placement_line(f, &best.label, p)?;
        }
        if let Some(between) = &self.between {
            for p in between
                .other
                .placements
                .iter()
                .filter(|p| p.role == Role::Primary)
            {
                placement_line(f, &between.other.label, p)?;
            }
        }
        let likely: Vec<String> = self
            .probabilities
            .iter()
            .filter(|s| s.probability >= 0.005)
            .map(|s| format!("{} {}", s.label, percent(s.probability)))
            .collect();
        if !likely.is_empty() {
            writeln!(f, "  sizes: {}", likely.join(", "))?;
        }
        for m in &self.missing {
            writeln!(
                f,
                "  missing: {} (secondary; neither measured nor estimated)",
                m.dimension
            )?;
        }
        Ok(())
    }
}

impl fmt::Display for Recommendation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "Sizes on \"{}\" (mm; probabilities take the dimensions as independent normals)",
            self.chart
        )?;
        for g in &self.garments {
            write!(f, "{g}")?;
        }
        Ok(())
    }
}
