//! `mtwin._mtwin`, the extension module of the Python package `mtwin` (PyO3, abi3).
//!
//! Glue only, as the command line is: arguments are checked and converted (numpy arrays
//! to records, strings to options), one function of the `identify` or `mtwin-fmu`
//! library is called with the GIL released, and its result is converted back (numpy
//! arrays, JSON text the Python layer turns into dicts). Every library error becomes
//! [`BadInputError`] (the user's input: the command line's exit code 2) or
//! [`MtwinError`] with the command line's message. The Python layer
//! (`python/mtwin/__init__.py`) adds the documented API on top.
// `#![forbid(unsafe_code)]` as in the other crates is impossible here: PyO3's macros
// expand to unsafe code; this file writes none.

use identify::axis::{Axis, Channel};
use identify::campaign::{identify_campaign, CampaignOptions};
use identify::diagnose::{diagnose as diagnose_twin, DiagnoseOptions};
use identify::frf::Frf;
use identify::interpolate::TwinEvaluator;
use identify::lobes::{lobes_sd, lobes_zoa, log_speeds, with_rigid_tool_tip, Cut, SdOptions, Tool};
use identify::rational_fit::{FitOptions, Weighting};
use identify::refit::{refit as refit_twin, RefitMethod, RefitOptions};
use identify::simulate::Hold;
use identify::spectra::{estimate_frf, Estimator, Excitation, FrfOptions};
use identify::timeseries::TimeSeries;
use identify::twin::Twin;
use mtwin_package::export::{export_fmu_as, FmiVersion};
use num_complex::Complex64;
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyException, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

pyo3::create_exception!(
    mtwin,
    MtwinError,
    PyException,
    "An mtwin operation failed (the message is the command line's)."
);
pyo3::create_exception!(
    mtwin,
    BadInputError,
    MtwinError,
    "The input is unusable (a bad file, record or option): what the command line reports with exit code 2."
);

/// The library's error as a Python exception; `context` is the word the command line puts
/// before the message (`identification`, `refit`, ...).
fn py_err(context: Option<&str>, e: identify::Error) -> PyErr {
    let text = match context {
        Some(c) => format!("{c}: {e}"),
        None => e.to_string(),
    };
    if e.is_bad_input() {
        BadInputError::new_err(text)
    } else {
        MtwinError::new_err(text)
    }
}

fn bad(msg: impl Into<String>) -> PyErr {
    BadInputError::new_err(msg.into())
}

/// A 1-D float64 numpy array as a vector; `what` names it in the error.
fn f64_vec(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let Ok(arr) = obj.cast::<PyUntypedArray>() else {
        return Err(PyTypeError::new_err(format!(
            "{what}: expected a numpy array of float64, got {}",
            obj.get_type().name()?
        )));
    };
    if arr.ndim() != 1 {
        return Err(PyValueError::new_err(format!(
            "{what}: expected a 1-D array, got shape {:?}",
            arr.shape()
        )));
    }
    let Ok(a) = obj.extract::<PyReadonlyArray1<'_, f64>>() else {
        return Err(PyTypeError::new_err(format!(
            "{what}: expected dtype float64, got {}",
            arr.dtype().str()?
        )));
    };
    Ok(a.as_array().iter().copied().collect())
}

/// A record: a time-series CSV path (str or os.PathLike), or a dict of 1-D float64 arrays
/// named as the columns of a time-series CSV (`t`, `fx`, `dx`, `ax`, `x`, ...). Reader
/// warnings are prefixed with the record's source, as the command line says them.
fn record(
    py: Python<'_>,
    i: usize,
    obj: &Bound<'_, PyAny>,
    warnings: &mut Vec<String>,
) -> PyResult<TimeSeries> {
    let (res, source) = if let Ok(d) = obj.cast::<PyDict>() {
        let source = format!("<record {i}>");
        let mut cols = Vec::with_capacity(d.len());
        for (k, v) in d.iter() {
            let name: String = k
                .extract()
                .map_err(|_| PyTypeError::new_err(format!("{source}: column names must be str")))?;
            let col = f64_vec(&format!("{source} column '{name}'"), &v)?;
            cols.push((name, col));
        }
        let src = PathBuf::from(&source);
        (
            py.detach(|| identify::read::timeseries_from_columns(&src, cols)),
            source,
        )
    } else if let Ok(p) = obj.extract::<PathBuf>() {
        let source = p.display().to_string();
        (
            py.detach(|| identify::read::read_timeseries_with_warnings(&p)),
            source,
        )
    } else {
        return Err(PyTypeError::new_err(format!(
            "record {i}: expected a path (str or os.PathLike) or a dict of numpy arrays, got {}",
            obj.get_type().name()?
        )));
    };
    let (ts, w) = res.map_err(|e| py_err(None, e))?;
    warnings.extend(w.into_iter().map(|w| format!("{source}: {w}")));
    Ok(ts)
}

fn records(
    py: Python<'_>,
    objs: &Bound<'_, PyAny>,
    warnings: &mut Vec<String>,
) -> PyResult<Vec<TimeSeries>> {
    if objs.is_instance_of::<pyo3::types::PyString>() || objs.cast::<PyDict>().is_ok() {
        return Ok(vec![record(py, 0, objs, warnings)?]);
    }
    let mut out = Vec::new();
    for (i, o) in objs.try_iter()?.enumerate() {
        out.push(record(py, i, &o?, warnings)?);
    }
    if out.is_empty() {
        return Err(bad("no records given"));
    }
    Ok(out)
}

fn frf_options(estimator: &str, excitation: &str, nfft: Option<usize>) -> PyResult<FrfOptions> {
    Ok(FrfOptions {
        estimator: match estimator {
            "h1" => Estimator::H1,
            "h2" => Estimator::H2,
            "hv" => Estimator::Hv,
            o => return Err(bad(format!("estimator '{o}': use h1, h2 or hv"))),
        },
        excitation: match excitation {
            "auto" => Excitation::Auto,
            "impact" => Excitation::Impact,
            "continuous" => Excitation::Continuous,
            "chirp" => Excitation::Chirp,
            o => {
                return Err(bad(format!(
                    "excitation '{o}': use auto, impact, continuous or chirp"
                )))
            }
        },
        nfft,
        ..FrfOptions::default()
    })
}

fn pose3(what: &str, v: Vec<f64>) -> PyResult<[f64; 3]> {
    match <[f64; 3]>::try_from(v) {
        Ok(p) if p.iter().all(|x| x.is_finite()) => Ok(p),
        Ok(p) => Err(PyValueError::new_err(format!(
            "{what}: {p:?} is not finite (X, Y, Z in metres)"
        ))),
        Err(v) => Err(PyValueError::new_err(format!(
            "{what}: expected 3 numbers X, Y, Z in metres, got {}",
            v.len()
        ))),
    }
}

/// The axes of `channels`' outputs and inputs, each sorted.
fn axes_of(channels: impl Iterator<Item = Channel> + Clone) -> (Vec<Axis>, Vec<Axis>) {
    let mut outs: Vec<Axis> = channels.clone().map(|c| c.output).collect();
    let mut ins: Vec<Axis> = channels.map(|c| c.input).collect();
    for v in [&mut outs, &mut ins] {
        v.sort();
        v.dedup();
    }
    (outs, ins)
}

fn letters(axes: &[Axis]) -> Vec<String> {
    axes.iter().map(|a| a.letter().to_string()).collect()
}

/// `frf` as the dict the Python layer shows: `f_hz`, `h` and `coherence` (lines × outputs
/// × inputs; NaN where the FRF has no such channel or no coherence), `outputs`, `inputs`.
fn frf_dict<'py>(py: Python<'py>, frf: &Frf) -> PyResult<Bound<'py, PyDict>> {
    let (outs, ins) = axes_of(frf.channels.iter().map(|c| c.channel));
    let n = frf.freqs_hz.len();
    let mut h = Array3::from_elem(
        (n, outs.len(), ins.len()),
        Complex64::new(f64::NAN, f64::NAN),
    );
    let mut g = Array3::from_elem((n, outs.len(), ins.len()), f64::NAN);
    for c in &frf.channels {
        let o = outs
            .iter()
            .position(|a| *a == c.channel.output)
            .unwrap_or(0);
        let i = ins.iter().position(|a| *a == c.channel.input).unwrap_or(0);
        for (k, v) in c.h.iter().enumerate() {
            h[[k, o, i]] = *v;
        }
        if let Some(coh) = &c.coherence {
            for (k, v) in coh.iter().enumerate() {
                g[[k, o, i]] = *v;
            }
        }
    }
    let d = PyDict::new(py);
    d.set_item("f_hz", PyArray1::from_slice(py, &frf.freqs_hz))?;
    d.set_item("h", h.into_pyarray(py))?;
    d.set_item("coherence", g.into_pyarray(py))?;
    d.set_item("outputs", letters(&outs))?;
    d.set_item("inputs", letters(&ins))?;
    Ok(d)
}

/// FRF estimate (receptance, m/N) and coherence of records, as `mtwin frf`.
#[pyfunction]
#[pyo3(signature = (records, *, estimator = "h1", excitation = "auto", nfft = None))]
fn frf<'py>(
    py: Python<'py>,
    records: &Bound<'py, PyAny>,
    estimator: &str,
    excitation: &str,
    nfft: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let opts = frf_options(estimator, excitation, nfft)?;
    let mut warnings = Vec::new();
    let series = self::records(py, records, &mut warnings)?;
    let est = py
        .detach(|| estimate_frf(&series, &opts))
        .map_err(|e| py_err(Some("FRF estimation"), e))?;
    warnings.extend(est.warnings.iter().cloned());
    let d = frf_dict(py, &est.frf)?;
    d.set_item("method", &est.method)?;
    d.set_item("df_hz", est.df_hz)?;
    d.set_item("averages", est.hits_used)?;
    d.set_item("dropped", est.hits_dropped.clone())?;
    d.set_item("exp_window_sigma", est.exp_window_sigma)?;
    d.set_item("warnings", warnings)?;
    Ok(d)
}

/// The twin identified from a campaign of records, as `mtwin identify`; returns the twin
/// and the warnings.
#[pyfunction]
#[pyo3(name = "identify", signature = (records, *, order = None, fmin = None, fmax = None, estimator = "h1",
    excitation = "auto", pose_tol = 1e-3, weighting = "auto", name = "machine", command = ""))]
#[allow(clippy::too_many_arguments)]
fn identify_twin<'py>(
    py: Python<'py>,
    records: &Bound<'py, PyAny>,
    order: Option<usize>,
    fmin: Option<f64>,
    fmax: Option<f64>,
    estimator: &str,
    excitation: &str,
    pose_tol: f64,
    weighting: &str,
    name: &str,
    command: &str,
) -> PyResult<(PyTwin, Vec<String>)> {
    if order == Some(0) {
        return Err(bad("order must be at least 1 (number of modes)"));
    }
    let weight = match weighting {
        "auto" | "coherence" => Weighting::Coherence,
        "ml" => Weighting::InverseVariance,
        "balanced" => Weighting::Balanced,
        "mobility" => Weighting::Mobility,
        o => {
            return Err(bad(format!(
                "weighting '{o}': use auto, coherence, ml, balanced or mobility"
            )))
        }
    };
    let opts = CampaignOptions {
        frf: frf_options(estimator, excitation, None)?,
        fit: FitOptions {
            n_modes: order,
            band_hz: match (fmin, fmax) {
                (None, None) => None,
                (lo, hi) => Some((lo.unwrap_or(0.0), hi.unwrap_or(f64::INFINITY))),
            },
            weighting: weight,
            ..FitOptions::default()
        },
        pose_tol_m: pose_tol,
        name: name.to_string(),
        try_ml_weighting: weighting == "auto",
        ..CampaignOptions::default()
    };
    let mut warnings = Vec::new();
    let series = self::records(py, records, &mut warnings)?;
    let mut res = py
        .detach(|| identify_campaign(&series, &opts, &|_, _| {}))
        .map_err(|e| py_err(Some("identification"), e))?;
    res.twin.provenance.command = command.to_string();
    if fmax.is_some() {
        identify::campaign::drop_automatic_band_hint(&mut res.warnings);
    }
    warnings.extend(res.warnings);
    Ok((PyTwin { inner: res.twin }, warnings))
}

/// Reads a twin file (the command line's schema).
#[pyfunction]
fn load(py: Python<'_>, path: PathBuf) -> PyResult<PyTwin> {
    let twin = py
        .detach(|| Twin::load(&path))
        .map_err(|e| py_err(None, e))?;
    Ok(PyTwin { inner: twin })
}

/// Stability lobes at a pose, as `mtwin lobes`: zero-order and semi-discretisation.
#[pyfunction]
#[pyo3(signature = (twin, pose, *, teeth = 2, diameter = 0.016, helix = 0.0, immersion = 1.0,
    up = false, kt = 6e8, kr = 0.3, rpm_min = 2000.0, rpm_max = 20000.0, speeds = 200,
    sd_speeds = None, sd_steps = 40))]
#[allow(clippy::too_many_arguments)]
fn lobes<'py>(
    py: Python<'py>,
    twin: &PyTwin,
    pose: Vec<f64>,
    teeth: usize,
    diameter: f64,
    helix: f64,
    immersion: f64,
    up: bool,
    kt: f64,
    kr: f64,
    rpm_min: f64,
    rpm_max: f64,
    speeds: usize,
    sd_speeds: Option<usize>,
    sd_steps: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let pose = pose3("pose", pose)?;
    if !(rpm_min > 0.0 && rpm_max > rpm_min && speeds >= 1) {
        return Err(bad(format!(
            "spindle speeds: need 0 < rpm_min < rpm_max and speeds >= 1 (got {rpm_min} .. {rpm_max}, {speeds})"
        )));
    }
    let tool = Tool {
        teeth,
        diameter_m: diameter,
        helix_deg: helix,
    };
    let cut = Cut {
        radial_immersion: immersion,
        down_milling: !up,
        kt,
        kr,
    };
    let t = &twin.inner;
    let (zoa, sd, rigid) = py
        .detach(|| -> identify::Result<_> {
            let mut ev = TwinEvaluator::new(t)?;
            let (model, rigid) = with_rigid_tool_tip(ev.model_at(pose).clone());
            let zoa = lobes_zoa(&model, &tool, &cut, &log_speeds(rpm_min, rpm_max, speeds))?;
            let n_sd = sd_speeds.unwrap_or(speeds);
            let sd = if n_sd > 0 {
                let opts = SdOptions {
                    steps: sd_steps.max(2),
                    ..SdOptions::default()
                };
                lobes_sd(
                    &model,
                    &tool,
                    &cut,
                    &log_speeds(rpm_min, rpm_max, n_sd),
                    &opts,
                )?
            } else {
                Vec::new()
            };
            Ok((zoa, sd, rigid))
        })
        .map_err(|e| py_err(None, e))?;
    let d = PyDict::new(py);
    for (key, pts) in [("zoa", &zoa), ("sd", &sd)] {
        let e = PyDict::new(py);
        e.set_item("rpm", PyArray1::from_iter(py, pts.iter().map(|p| p.rpm)))?;
        e.set_item(
            "ap_lim_m",
            PyArray1::from_iter(py, pts.iter().map(|p| p.ap_lim_m)),
        )?;
        e.set_item(
            "chatter_hz",
            PyArray1::from_iter(py, pts.iter().map(|p| p.chatter_hz)),
        )?;
        d.set_item(key, e)?;
    }
    d.set_item(
        "rigid_channels",
        rigid.iter().map(Channel::name).collect::<Vec<_>>(),
    )?;
    Ok(d)
}

/// What [`PyTwin::simulate`] returns: times, displacement (samples × 3), output axes.
type Simulated<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, numpy::PyArray2<f64>>,
    Vec<String>,
);

/// A twin (the command line's twin file in memory).
#[pyclass(name = "Twin", module = "mtwin._mtwin", frozen)]
#[derive(Debug)]
struct PyTwin {
    inner: Twin,
}

#[pymethods]
impl PyTwin {
    /// The whole twin as the JSON text of its file.
    fn to_json(&self, py: Python<'_>) -> PyResult<String> {
        let t = &self.inner;
        py.detach(|| serde_json::to_string_pretty(t))
            .map_err(|e| MtwinError::new_err(format!("twin to JSON: {e}")))
    }

    /// Writes the twin file (atomically).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let t = &self.inner;
        py.detach(|| t.save(&path)).map_err(|e| py_err(None, e))
    }

    /// The GUID of the twin's FMU.
    fn guid(&self) -> String {
        self.inner.guid()
    }

    /// Channel names (`xx` = response x to force x), outputs and inputs.
    fn channels(&self) -> (Vec<String>, Vec<String>, Vec<String>) {
        let ch = self.inner.channels.iter().copied();
        let (outs, ins) = axes_of(ch.clone());
        (
            ch.map(|c| c.name()).collect(),
            letters(&outs),
            letters(&ins),
        )
    }

    /// The receptance at `pose` for the frequencies `f_hz`, as `mtwin eval` (pose models
    /// interpolated; the nearest point of the measured box outside it); also whether the
    /// pose is inside the measured box.
    fn eval<'py>(
        &self,
        py: Python<'py>,
        pose: Vec<f64>,
        f_hz: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyDict>, bool)> {
        let pose = pose3("pose", pose)?;
        let f = f64_vec("f_hz", f_hz)?;
        if let Some(x) = f.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
            return Err(PyValueError::new_err(format!(
                "f_hz: {x} is not a frequency in Hz (finite, non-negative)"
            )));
        }
        let t = &self.inner;
        let (frf, inside) = py
            .detach(|| -> identify::Result<_> {
                let mut ev = TwinEvaluator::new(t)?;
                let inside = ev.is_inside(pose);
                Ok((ev.model_at(pose).frf(&f), inside))
            })
            .map_err(|e| py_err(None, e))?;
        Ok((frf_dict(py, &frf)?, inside))
    }

    /// Predicted TCP displacement for a record's forces and positions, as `mtwin
    /// simulate`: returns the times, the displacement (samples × 3, axes x, y, z) and the
    /// twin's output axes.
    #[pyo3(signature = (record, hold = "zoh"))]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        record: &Bound<'py, PyAny>,
        hold: &str,
    ) -> PyResult<Simulated<'py>> {
        let hold = match hold {
            "zoh" => Hold::Zoh,
            "foh" => Hold::Foh,
            "band" => Hold::BandLimited,
            o => return Err(bad(format!("hold '{o}': use zoh, foh or band"))),
        };
        let mut warnings = Vec::new();
        let ts = self::record(py, 0, record, &mut warnings)?;
        let t = &self.inner;
        let y = py
            .detach(|| t.simulate(&ts, hold))
            .map_err(|e| py_err(None, e))?;
        let mut arr = Array2::zeros((y.len(), 3));
        for (i, r) in y.iter().enumerate() {
            for k in 0..3 {
                arr[[i, k]] = r[k];
            }
        }
        let (outs, _) = axes_of(t.channels.iter().copied());
        Ok((
            PyArray1::from_vec(py, ts.times()),
            arr.into_pyarray(py),
            letters(&outs),
        ))
    }

    /// The lifetime update from operating records, as `mtwin refit`: the new twin (with
    /// the whole history) and the report as JSON text.
    #[pyo3(signature = (records, *, method = "time", drift_threshold = 5.0, force = false,
        psd_threshold = None, min_coherence = 0.8, spread_length = None, command = ""))]
    #[allow(clippy::too_many_arguments)]
    fn refit<'py>(
        &self,
        py: Python<'py>,
        records: &Bound<'py, PyAny>,
        method: &str,
        drift_threshold: f64,
        force: bool,
        psd_threshold: Option<f64>,
        min_coherence: f64,
        spread_length: Option<f64>,
        command: &str,
    ) -> PyResult<(PyTwin, String, Vec<String>)> {
        let opts = RefitOptions {
            method: match method {
                "time" => RefitMethod::Time,
                "modal" => RefitMethod::Modal,
                "paper" => RefitMethod::Paper,
                o => return Err(bad(format!("method '{o}': use time, modal or paper"))),
            },
            drift_threshold_pct: drift_threshold,
            force,
            psd_threshold,
            min_coherence,
            spread_length_m: spread_length,
            ..RefitOptions::default()
        };
        let mut warnings = Vec::new();
        let series = self::records(py, records, &mut warnings)?;
        let t = &self.inner;
        let (mut new, rep) = py
            .detach(|| refit_twin(t, &series, &opts))
            .map_err(|e| py_err(Some("refit"), e))?;
        new.provenance.command = command.to_string();
        let json = serde_json::to_string(&rep)
            .map_err(|e| MtwinError::new_err(format!("refit report to JSON: {e}")))?;
        Ok((PyTwin { inner: new }, json, warnings))
    }

    /// What the twin gets wrong on measured records, as `mtwin diagnose`: the diagnosis
    /// as JSON text and the extended twin.
    #[pyo3(signature = (records, *, holdout = 0.3))]
    fn diagnose<'py>(
        &self,
        py: Python<'py>,
        records: &Bound<'py, PyAny>,
        holdout: f64,
    ) -> PyResult<(String, PyTwin, Vec<String>)> {
        let opts = DiagnoseOptions {
            holdout_fraction: holdout.clamp(0.05, 0.8),
            ..DiagnoseOptions::default()
        };
        let mut warnings = Vec::new();
        let series = self::records(py, records, &mut warnings)?;
        let t = &self.inner;
        let (diag, ext) = py
            .detach(|| diagnose_twin(t, &series, &opts))
            .map_err(|e| py_err(Some("diagnosis"), e))?;
        let json = serde_json::to_string(&diag)
            .map_err(|e| MtwinError::new_err(format!("diagnosis to JSON: {e}")))?;
        Ok((json, PyTwin { inner: ext }, warnings))
    }

    /// Writes the twin's co-simulation FMU (atomically), as `mtwin export`; `slave` is
    /// the FMU slave library `libmtwin_fmu.so` to package (the wheel ships one).
    /// Returns the sizes in bytes.
    #[pyo3(signature = (path, *, fmi = 2, slave = None))]
    fn export_fmu<'py>(
        &self,
        py: Python<'py>,
        path: PathBuf,
        fmi: u8,
        slave: Option<PathBuf>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let version = match fmi {
            2 => FmiVersion::V2,
            3 => FmiVersion::V3,
            o => return Err(bad(format!("fmi {o}: use 2 or 3"))),
        };
        let t = &self.inner;
        let size = py
            .detach(|| -> identify::Result<_> {
                let bytes = match &slave {
                    Some(p) => Some(std::fs::read(p).map_err(|e| identify::Error::io(p, e))?),
                    None => None,
                };
                export_fmu_as(t, &path, bytes.as_deref(), version)
            })
            .map_err(|e| py_err(None, e))?;
        let d = PyDict::new(py);
        d.set_item("fmu", size.fmu)?;
        d.set_item("unpacked", size.unpacked)?;
        d.set_item("slave_library", size.library)?;
        d.set_item("resources", size.resources)?;
        d.set_item("model_description", size.model_description)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let t = &self.inner;
        format!(
            "<mtwin.Twin '{}': {}, channels {}, {}>",
            t.name,
            identify::axis::count(t.poses.len(), "pose"),
            t.channels
                .iter()
                .map(|c| c.name())
                .collect::<Vec<_>>()
                .join(","),
            identify::axis::count(t.history.len(), "history entry")
        )
    }
}

/// The extension module.
#[pymodule]
fn _mtwin(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("MtwinError", m.py().get_type::<MtwinError>())?;
    m.add("BadInputError", m.py().get_type::<BadInputError>())?;
    m.add_class::<PyTwin>()?;
    m.add_function(wrap_pyfunction!(frf, m)?)?;
    m.add_function(wrap_pyfunction!(identify_twin, m)?)?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(lobes, m)?)?;
    Ok(())
}
