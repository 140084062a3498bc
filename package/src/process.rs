//! The process FMU's package: its `modelDescription.xml` (the cutting parameters as
//! FMI parameters with units) and the archive with `resources/cut.json`.

use model_description::{ModelDescription, Real};
use mtwin_fmu::process::{Cut, CutResource, MODEL_IDENTIFIER, PARAMS};

/// `modelDescription.xml` of the process FMU with `cut` as the parameters' start values.
pub fn model_description(cut: &Cut, guid: &str, unix_time: u64) -> ModelDescription {
    let mut md = ModelDescription::co_simulation(
        "mtwin regenerative milling process",
        guid,
        MODEL_IDENTIFIER,
    );
    md.description = Some(
        "Linear regenerative milling force model (the delay line inside): inputs the tool \
         displacement relative to the workpiece from the twin FMU (dx, dy), outputs the \
         cutting force on the tool (Fx, Fy) for the twin FMU; machine axis frame, SI units"
            .into(),
    );
    md.generation_tool = Some(format!("mtwin {}", env!("CARGO_PKG_VERSION")));
    md.generation_date_and_time = Some(mtwin_fmu::resources::utc_iso(unix_time));
    md.default_experiment = Some(model_description::DefaultExperiment {
        start_time: Some(0.0),
        stop_time: Some(1.0),
        step_size: Some(1e-5),
    });
    for (n, desc) in [
        (
            "dx",
            "Displacement of the tool relative to the workpiece along x, in m (the twin FMU's dx)",
        ),
        (
            "dy",
            "Displacement of the tool relative to the workpiece along y, in m (the twin FMU's dy)",
        ),
    ] {
        let real = Real {
            quantity: Some("Length".into()),
            unit: Some("m".into()),
            start: Some(0.0),
            ..Real::default()
        };
        md = md.with_described_real(n, "input", desc, real);
    }
    for (n, a) in [("Fx", "x"), ("Fy", "y")] {
        let real = Real {
            quantity: Some("Force".into()),
            unit: Some("N".into()),
            ..Real::default()
        };
        let d = format!(
            "Cutting force on the tool along {a}, in N (the twin FMU's F{a}); read after \
             setting dx, dy at t, it includes their direct effect (direct feedthrough)"
        );
        md = md.with_described_real(n, "output", &d, real);
    }
    for p in &PARAMS {
        let real = Real {
            quantity: p.quantity.map(Into::into),
            unit: p.unit.map(Into::into),
            start: Some((p.get)(cut)),
            ..Real::default()
        };
        md = md.with_described_real(p.name, "parameter", p.description, real);
        if let Some(v) = md.model_variables.variables.last_mut() {
            v.variability = Some("fixed".into());
            v.initial = Some("exact".into());
        }
    }
    let mut units: Vec<&str> = PARAMS.iter().filter_map(|p| p.unit).collect();
    units.extend(["m", "N"]);
    units.sort_unstable();
    units.dedup();
    md.unit_definitions = Some(model_description::UnitDefinitions {
        units: units
            .into_iter()
            .map(|u| model_description::Unit {
                name: u.into(),
                base_unit: base_unit(u),
            })
            .collect(),
    });
    md
}

fn base_unit(u: &str) -> Option<model_description::BaseUnit> {
    let b = |kg, m, s| {
        Some(model_description::BaseUnit {
            kg: Some(kg).filter(|v| *v != 0),
            m: Some(m).filter(|v| *v != 0),
            s: Some(s).filter(|v| *v != 0),
        })
    };
    match u {
        "N" => b(1, 1, -2),
        "m" => b(0, 1, 0),
        "s" => b(0, 0, 1),
        "N/m2" => b(1, -1, -2),
        "1/min" => b(0, 0, -1),
        "1" => b(0, 0, 0),
        _ => None,
    }
}

/// Writes the process FMU of `cut` (the parameters' start values) to `out` atomically,
/// with the slave library as for the twin FMU ([`crate::export::export_fmu_with`]).
pub fn export_process_fmu(
    cut: &Cut,
    out: &std::path::Path,
    embedded: Option<&[u8]>,
) -> Result<crate::export::FmuSize, mtwin_core::Error> {
    cut.validate().map_err(mtwin_core::Error::BadInput)?;
    let res = CutResource::new(cut.clone());
    let xml = model_description(cut, &res.guid, mtwin_core::twin::now_unix())
        .to_xml()
        .map_err(|e| mtwin_core::Error::BadInput(format!("modelDescription.xml: {e}")))?;
    let json = serde_json::to_vec_pretty(&res)
        .map_err(|e| mtwin_core::Error::BadInput(format!("cut.json: {e}")))?;
    crate::export::package(
        out,
        &xml,
        &crate::export::FmiVersion::V2.binary_path(MODEL_IDENTIFIER),
        embedded,
        &[("resources/cut.json", &json)],
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtwin_fmu::process::name;

    #[test]
    fn the_model_description_names_every_parameter_with_a_unit_or_none() {
        let md = model_description(&Cut::default(), "{g}", 0);
        let xml = md.to_xml().unwrap();
        let back = ModelDescription::from_xml(&xml).unwrap();
        assert_eq!(back, md);
        let vars = &md.model_variables.variables;
        assert_eq!(vars.len(), 4 + PARAMS.len());
        for (i, v) in vars.iter().enumerate() {
            assert_eq!(v.value_reference, i as u32);
            assert_eq!(name(i as u32), v.name);
            assert!(v.description.is_some());
        }
        // Fx, Fy depend on dx, dy (indices 1, 2)
        for u in &md.model_structure.outputs.unknowns {
            assert_eq!(u.dependencies.as_deref(), Some("1 2"));
        }
    }
}
