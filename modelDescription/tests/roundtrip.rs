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
