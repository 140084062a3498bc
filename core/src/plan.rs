//! The plan of a pose: the automatic decisions between the FRF estimate and the fit
//! (band, channels, excitation, alternatives tried), kept with their evidence in the twin
//! file. The decisions themselves are made by `identify::plan` (see its module docs).

use crate::axis::Channel;
use serde::{Deserialize, Serialize};

/// The decision about one channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelDecision {
    /// The channel.
    pub channel: Channel,
    /// Fitted (true) or left out as noise (false).
    pub used: bool,
    /// Fraction of the band's lines whose coherence is significant (when judged).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub significant_fraction: Option<f64>,
    /// The channel's own trusted band \[Hz\] inside the pose band, when its coherence
    /// reaches the trust level on a narrower range than the pose's best channel (a cross
    /// channel whose response sinks into the noise at high frequency). The channel's fit
    /// and noise limit are judged inside it; the fit itself still sees the lines outside
    /// with their (low) coherence weight: zeroing them was measured to cost the
    /// interpolated twin 2-7 points on the tryout campaign's unmeasured poses.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub band_hz: Option<[f64; 2]>,
    /// Why.
    pub reason: String,
}

/// The plan of one pose: what the fit will use, with the evidence.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PosePlan {
    /// Excitation recognised and the estimator used.
    pub excitation: String,
    /// Number of averages of the estimate (hits, segments), when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub averages: Option<usize>,
    /// Averages behind each channel's estimate (the fewest over the channels), when it
    /// differs from `averages`: an x and a y hammer test of 5 hits each are 10 averages,
    /// each channel's H1 rests on its own force direction's 5. The channels' noise limits
    /// and noise-free fit estimates are computed with it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub averages_per_channel: Option<usize>,
    /// The fitted band \[Hz\].
    pub band_hz: [f64; 2],
    /// Why this band (one line per step).
    pub band_evidence: Vec<String>,
    /// One decision per channel of the FRF.
    pub channels: Vec<ChannelDecision>,
    /// Fits tried after the first one, and which was kept.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub alternatives: Vec<String>,
    /// Warnings about the model's quality at this pose (empty when it fits its data).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub quality_warnings: Vec<String>,
    /// The quantity the sensor measured, when known: the pose's `fit` is computed on that
    /// FRF (accelerance for an accelerometer), the one the user's own estimate shows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measured_as: Option<MeasuredAs>,
}

/// The band of each channel: the pose's, or the channel's own narrower one
/// ([`ChannelDecision::band_hz`]). Every fit figure is computed per channel in its band.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Bands {
    /// The pose band \[Hz\].
    pub pose: (f64, f64),
    /// Channels with a narrower band of their own.
    pub narrower: Vec<(Channel, (f64, f64))>,
}

impl Bands {
    /// Every channel in `band`.
    pub fn whole(band: (f64, f64)) -> Self {
        Bands {
            pose: band,
            narrower: Vec::new(),
        }
    }

    /// The band of `channel`: its own (inside the pose band) or the pose's.
    pub fn of(&self, channel: Channel) -> (f64, f64) {
        self.narrower
            .iter()
            .find(|(c, _)| *c == channel)
            .map_or(self.pose, |&(_, (a, b))| {
                (a.max(self.pose.0), b.min(self.pose.1))
            })
    }

    /// The same channel bands inside another pose band `band` (a part of it).
    pub fn within(&self, band: (f64, f64)) -> Self {
        Bands {
            pose: band,
            narrower: self.narrower.clone(),
        }
    }

    /// `Some(band)` of `channel` when it differs from the pose band.
    pub fn own(&self, channel: Channel) -> Option<[f64; 2]> {
        let b = self.of(channel);
        (b != self.pose).then_some([b.0, b.1])
    }
}

impl From<(f64, f64)> for Bands {
    fn from(band: (f64, f64)) -> Self {
        Bands::whole(band)
    }
}

/// What the response sensor measured: the FRF the data gives directly.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MeasuredAs {
    /// Displacement: receptance (m/N).
    Receptance,
    /// Velocity: mobility ((m/s)/N).
    Mobility,
    /// Acceleration: accelerance ((m/s²)/N).
    Accelerance,
}

impl MeasuredAs {
    /// The power of `jω` that turns a receptance into this FRF.
    pub fn power(self) -> i32 {
        match self {
            MeasuredAs::Receptance => 0,
            MeasuredAs::Mobility => 1,
            MeasuredAs::Accelerance => 2,
        }
    }

    /// Its name (`receptance`, `mobility`, `accelerance`).
    pub fn name(self) -> &'static str {
        match self {
            MeasuredAs::Receptance => "receptance",
            MeasuredAs::Mobility => "mobility",
            MeasuredAs::Accelerance => "accelerance",
        }
    }
}

impl PosePlan {
    /// The used channels' own narrower bands (see [`ChannelDecision::band_hz`]).
    pub fn channel_bands(&self) -> Vec<(Channel, (f64, f64))> {
        self.channels
            .iter()
            .filter(|c| c.used)
            .filter_map(|c| c.band_hz.map(|b| (c.channel, (b[0], b[1]))))
            .collect()
    }

    /// The bands in which each channel is fitted and judged, inside `pose_band`.
    pub fn bands(&self, pose_band: (f64, f64)) -> Bands {
        Bands {
            pose: pose_band,
            narrower: self.channel_bands(),
        }
    }

    /// The channels the fit uses.
    pub fn used_channels(&self) -> Vec<Channel> {
        self.channels
            .iter()
            .filter(|c| c.used)
            .map(|c| c.channel)
            .collect()
    }
}
