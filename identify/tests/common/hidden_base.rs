//! The base twins of `vmachine::hidden`'s cases, identified here: the generator makes
//! data and truth only (it judges the identification and does not call it).

use identify::axis::Axis;
use identify::campaign::{identify_campaign, CampaignOptions};
use identify::rational_fit::FitOptions;
use identify::twin::Twin;
use vmachine::hidden::{base_tests, BaseTwins, AXES, BASE_BAND_HZ};
use vmachine::structure::ModalMachine;

/// The twin of `m` from clean tests at the cases' pose with hammer and responses along
/// `axes`, in the cases' band, automatic order.
pub fn base_twin(m: &ModalMachine, axes: &[Axis]) -> Twin {
    let opts = CampaignOptions {
        fit: FitOptions {
            band_hz: Some(BASE_BAND_HZ),
            ..FitOptions::default()
        },
        ..CampaignOptions::default()
    };
    identify_campaign(&base_tests(m, axes), &opts, &|_, _| {})
        .expect("identification of the base twin")
        .twin
}

/// Both base twins of the default machine.
#[allow(dead_code)] // each test binary uses part of this module
pub fn base_twins() -> BaseTwins {
    let m = ModalMachine::default_machine();
    BaseTwins {
        xy: base_twin(&m, &AXES),
        x: base_twin(&m, &[Axis::X]),
    }
}
