//! The checked-in modelDescription.xml reads, writes and reads back identically.

use model_description::ModelDescription;

#[test]
fn checked_in_file_round_trips() {
    let text = include_str!("data/modelDescription.xml");
    let md = ModelDescription::from_xml(text).expect("parse");
    assert_eq!(md.fmi_version, "2.0");
    assert_eq!(md.co_simulation.model_identifier, "mtwin_tcp");
    assert_eq!(
        md.co_simulation.can_handle_variable_communication_step_size,
        Some(true)
    );
    let names: Vec<&str> = md
        .model_variables
        .variables
        .iter()
        .map(|v| v.name.as_str())
        .collect();
    assert_eq!(names, ["Fx", "Fy", "x", "y", "z", "dx", "dy"]);
    // outputs dx, dy are variables 6 and 7 (1-based)
    let idx: Vec<u32> = md
        .model_structure
        .outputs
        .unknowns
        .iter()
        .map(|u| u.index)
        .collect();
    assert_eq!(idx, [6, 7]);
    let inputs = md
        .model_variables
        .variables
        .iter()
        .filter(|v| v.causality.as_deref() == Some("input"));
    for v in inputs {
        assert!(v.real.start.is_some() && v.initial.is_none(), "{}", v.name);
    }
    let again = ModelDescription::from_xml(&md.to_xml().unwrap()).unwrap();
    assert_eq!(again, md);
}

/// The checked-in FMI 3.0 file reads, writes and reads back identically, and is exactly
/// what the FMI 2.0 file of the same FMU converts to (one variable table for both).
#[test]
fn checked_in_fmi3_file_round_trips_and_matches_the_fmi2_file() {
    use model_description::fmi3;
    let text = include_str!("data/modelDescription3.xml");
    let md = fmi3::ModelDescription::from_xml(text).expect("parse");
    assert_eq!(md.fmi_version, "3.0");
    assert_eq!(
        md.instantiation_token,
        "{8c4e810f-3df3-4a00-8276-176fa3c9f000}"
    );
    assert_eq!(md.co_simulation.model_identifier, "mtwin_tcp");
    assert_eq!(
        md.co_simulation.can_handle_variable_communication_step_size,
        Some(true)
    );
    let names: Vec<&str> = md
        .model_variables
        .variables
        .iter()
        .map(|v| v.name.as_str())
        .collect();
    assert_eq!(names, ["time", "Fx", "Fy", "x", "y", "z", "dx", "dy"]);
    assert_eq!(md.value_reference("time"), Some(7));
    let units: Vec<(&str, Option<&str>)> = md
        .model_variables
        .variables
        .iter()
        .map(|v| {
            let t = md.declared_type(v).expect("declaredType");
            (v.name.as_str(), t.unit.as_deref())
        })
        .collect();
    assert_eq!(units[0], ("time", Some("s")));
    assert_eq!(units[1], ("Fx", Some("N")));
    assert_eq!(units[7], ("dy", Some("m")));
    let outs: Vec<(u32, Option<&str>)> = md
        .model_structure
        .outputs
        .iter()
        .map(|u| (u.value_reference, u.dependencies.as_deref()))
        .collect();
    assert_eq!(outs, [(5, Some("0 1 2 3 4")), (6, Some("0 1 2 3 4"))]);
    let again = fmi3::ModelDescription::from_xml(&md.to_xml().unwrap()).unwrap();
    assert_eq!(again, md);

    let md2 = ModelDescription::from_xml(include_str!("data/modelDescription.xml")).unwrap();
    assert_eq!(fmi3::ModelDescription::from_fmi2(&md2), md);
}
