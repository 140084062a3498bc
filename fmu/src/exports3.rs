//! The `extern "C"` functions of FMI 3.0, exported by the same library as the FMI 2.0
//! ones (the `fmi3` prefix exists so that one binary can carry both) and driving the same
//! [`Slave`]. Co-Simulation only, without event mode: what the FMU supports goes to the
//! slave, every other function of the standard is exported too (an importer may look up
//! all of them) and returns `fmi3Error` with a logged reason. Every function goes through
//! [`call`] (null check, refusal after a panic, `catch_unwind`, error → `fmi3Error`,
//! panic → `fmi3Fatal`).
//!
//! # Safety (all functions)
//! The importer must pass the pointers the FMI 3.0 standard prescribes: `instance` an
//! instance returned by `fmi3InstantiateCoSimulation` and not yet freed (NULL is
//! detected), arrays valid for the given lengths (NULL with length 0 is fine), strings
//! NUL-terminated.

use crate::ffi::*;
use crate::model::Model;
use crate::trampoline::{
    call, deserialize_state, free, free_state, get_state, guard, into_raw, load_slave, no_such,
    resource_dir, serialize_state, set_state, slice, slice_mut, state_size, string, Api, Instance,
    Logger, Status,
};
use std::ffi::{c_char, CString};
use std::path::PathBuf;

/// The resources folder from `resourcePath`: an absolute path with a trailing separator
/// (FMI 3.0; taken as it is), or a `file:` URI as FMI 2.0 passed it.
fn resources(loc: &str) -> Result<PathBuf, String> {
    if loc.starts_with("file:") {
        resource_dir(loc)
    } else {
        Ok(PathBuf::from(loc))
    }
}

fn instantiate(
    name: &str,
    token: Option<String>,
    loc: Option<String>,
    event_mode_used: bool,
) -> Result<Model, String> {
    if event_mode_used {
        return Err(
            "eventModeUsed is true but this FMU has no event mode (hasEventMode=\"false\")".into(),
        );
    }
    let loc = loc.ok_or("resourcePath is NULL (the FMU needs its resources/twin.json)")?;
    let mut slave = load_slave(Api::Fmi3, name, token, resources(&loc)?)?;
    slave.expose_time()?;
    Ok(slave)
}

/// NULL after logging `msg` (an instantiation that cannot be).
fn refuse(
    logger: Fmi3LogMessageCallback,
    env: Fmi3InstanceEnvironment,
    what: &str,
    msg: &str,
) -> Fmi3Instance {
    Logger::Fmi3(logger, env).log(
        c"mtwin",
        Status::Error,
        "logStatusError",
        &format!("{what}: {msg}"),
    );
    std::ptr::null_mut()
}

/// `fmi3GetVersion`.
#[no_mangle]
pub extern "C" fn fmi3GetVersion() -> *const c_char {
    c"3.0".as_ptr()
}

/// `fmi3InstantiateCoSimulation`. Returns NULL (after logging why) on any problem.
///
/// # Safety
/// See the module docs.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
    instance_name: Fmi3String,
    instantiation_token: Fmi3String,
    resource_path: Fmi3String,
    _visible: Fmi3Boolean,
    logging_on: Fmi3Boolean,
    event_mode_used: Fmi3Boolean,
    _early_return_allowed: Fmi3Boolean,
    _required_intermediate_variables: *const Fmi3ValueReference,
    _n_required_intermediate_variables: usize,
    instance_environment: Fmi3InstanceEnvironment,
    log_message: Fmi3LogMessageCallback,
    _intermediate_update: Fmi3IntermediateUpdateCallback,
) -> Fmi3Instance {
    guard(std::ptr::null_mut(), || {
        // SAFETY: strings are NULL or NUL-terminated (module contract).
        let name = unsafe { string(instance_name) }.unwrap_or_else(|| "mtwin".into());
        // SAFETY: as above.
        let token = unsafe { string(instantiation_token) };
        // SAFETY: as above.
        let loc = unsafe { string(resource_path) };
        let cname = CString::new(name.replace('\0', " ")).unwrap_or_default();
        let logger = Logger::Fmi3(log_message, instance_environment);
        match instantiate(&name, token, loc, event_mode_used) {
            Ok(slave) => into_raw(Instance::new(cname, logger, logging_on, slave)),
            Err(msg) => {
                logger.log(
                    &cname,
                    Status::Error,
                    "logStatusError",
                    &format!("fmi3InstantiateCoSimulation: {msg}"),
                );
                std::ptr::null_mut()
            }
        }
    })
}

/// `fmi3InstantiateModelExchange`: NULL (Co-Simulation only).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3InstantiateModelExchange(
    _instance_name: Fmi3String,
    _instantiation_token: Fmi3String,
    _resource_path: Fmi3String,
    _visible: Fmi3Boolean,
    _logging_on: Fmi3Boolean,
    instance_environment: Fmi3InstanceEnvironment,
    log_message: Fmi3LogMessageCallback,
) -> Fmi3Instance {
    refuse(
        log_message,
        instance_environment,
        "fmi3InstantiateModelExchange",
        "this FMU supports Co-Simulation only",
    )
}

/// `fmi3InstantiateScheduledExecution`: NULL (Co-Simulation only).
///
/// # Safety
/// See the module docs.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn fmi3InstantiateScheduledExecution(
    _instance_name: Fmi3String,
    _instantiation_token: Fmi3String,
    _resource_path: Fmi3String,
    _visible: Fmi3Boolean,
    _logging_on: Fmi3Boolean,
    instance_environment: Fmi3InstanceEnvironment,
    log_message: Fmi3LogMessageCallback,
    _clock_update: Fmi3ClockUpdateCallback,
    _lock_preemption: Fmi3PreemptionCallback,
    _unlock_preemption: Fmi3PreemptionCallback,
) -> Fmi3Instance {
    refuse(
        log_message,
        instance_environment,
        "fmi3InstantiateScheduledExecution",
        "this FMU supports Co-Simulation only",
    )
}

/// `fmi3FreeInstance`.
///
/// # Safety
/// See the module docs; `instance` must not be used afterwards.
#[no_mangle]
pub unsafe extern "C" fn fmi3FreeInstance(instance: Fmi3Instance) {
    // SAFETY: NULL or from fmi3InstantiateCoSimulation, freed once (module docs).
    unsafe { free(instance) };
}

/// `fmi3SetDebugLogging`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetDebugLogging(
    instance: Fmi3Instance,
    logging_on: Fmi3Boolean,
    _n_categories: usize,
    _categories: *const Fmi3String,
) -> Fmi3Status {
    call(instance, "fmi3SetDebugLogging", |i| {
        i.debug = logging_on;
        Ok(Status::Ok)
    })
}

/// `fmi3EnterInitializationMode` (the start time is taken; tolerance and stop time are
/// not needed).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3EnterInitializationMode(
    instance: Fmi3Instance,
    _tolerance_defined: Fmi3Boolean,
    _tolerance: Fmi3Float64,
    start_time: Fmi3Float64,
    _stop_time_defined: Fmi3Boolean,
    _stop_time: Fmi3Float64,
) -> Fmi3Status {
    call(instance, "fmi3EnterInitializationMode", |i| {
        i.slave.setup(start_time)?;
        i.slave.enter_init().map(|_| Status::Ok)
    })
}

/// `fmi3ExitInitializationMode` (into Step Mode).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3ExitInitializationMode(instance: Fmi3Instance) -> Fmi3Status {
    call(instance, "fmi3ExitInitializationMode", |i| {
        i.slave.exit_init().map(|_| Status::Ok)
    })
}

/// `fmi3Terminate`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3Terminate(instance: Fmi3Instance) -> Fmi3Status {
    call(instance, "fmi3Terminate", |i| {
        i.slave.terminate().map(|_| Status::Ok)
    })
}

/// `fmi3Reset`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3Reset(instance: Fmi3Instance) -> Fmi3Status {
    call(instance, "fmi3Reset", |i| {
        i.slave.reset();
        Ok(Status::Ok)
    })
}

/// Every variable is a scalar: as many values as value references.
fn scalars(nvr: usize, n_values: usize) -> Result<(), String> {
    if nvr == n_values {
        Ok(())
    } else {
        Err(format!(
            "{} for {} (every variable of this FMU is a scalar)",
            mtwin_core::axis::count(n_values, "value"),
            mtwin_core::axis::count(nvr, "value reference")
        ))
    }
}

/// `fmi3GetFloat64`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetFloat64(
    instance: Fmi3Instance,
    value_references: *const Fmi3ValueReference,
    n_value_references: usize,
    values: *mut Fmi3Float64,
    n_values: usize,
) -> Fmi3Status {
    call(instance, "fmi3GetFloat64", |i| {
        scalars(n_value_references, n_values)?;
        // SAFETY: arrays valid for their lengths (module contract; NULL detected).
        let vr = unsafe { slice(value_references, n_value_references, "valueReferences") }?;
        // SAFETY: as above.
        let out = unsafe { slice_mut(values, n_values, "values") }?;
        i.slave.get_real(vr, out)?;
        Ok(i.warn())
    })
}

/// `fmi3SetFloat64`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetFloat64(
    instance: Fmi3Instance,
    value_references: *const Fmi3ValueReference,
    n_value_references: usize,
    values: *const Fmi3Float64,
    n_values: usize,
) -> Fmi3Status {
    call(instance, "fmi3SetFloat64", |i| {
        scalars(n_value_references, n_values)?;
        // SAFETY: arrays valid for their lengths (module contract; NULL detected).
        let vr = unsafe { slice(value_references, n_value_references, "valueReferences") }?;
        // SAFETY: as above.
        let v = unsafe { slice(values, n_values, "values") }?;
        i.slave.set_real(vr, v).map(|_| Status::Ok)
    })
}

/// Getters and setters of the types this FMU has no variables of: fine for none, else
/// `fmi3Error`.
macro_rules! no_variables {
    ($($get:ident, $set:ident, $ty:ty, $kind:literal;)*) => {$(
        #[doc = concat!("`", stringify!($get), "` (no ", $kind, " variables).")]
        ///
        /// # Safety
        /// See the module docs.
        #[no_mangle]
        pub unsafe extern "C" fn $get(
            instance: Fmi3Instance,
            _value_references: *const Fmi3ValueReference,
            n_value_references: usize,
            _values: *mut $ty,
            _n_values: usize,
        ) -> Fmi3Status {
            call(instance, stringify!($get), |_| no_such($kind, n_value_references))
        }

        #[doc = concat!("`", stringify!($set), "` (no ", $kind, " variables).")]
        ///
        /// # Safety
        /// See the module docs.
        #[no_mangle]
        pub unsafe extern "C" fn $set(
            instance: Fmi3Instance,
            _value_references: *const Fmi3ValueReference,
            n_value_references: usize,
            _values: *const $ty,
            _n_values: usize,
        ) -> Fmi3Status {
            call(instance, stringify!($set), |_| no_such($kind, n_value_references))
        }
    )*};
}

no_variables! {
    fmi3GetFloat32, fmi3SetFloat32, f32, "Float32";
    fmi3GetInt8, fmi3SetInt8, i8, "Int8";
    fmi3GetUInt8, fmi3SetUInt8, u8, "UInt8";
    fmi3GetInt16, fmi3SetInt16, i16, "Int16";
    fmi3GetUInt16, fmi3SetUInt16, u16, "UInt16";
    fmi3GetInt32, fmi3SetInt32, i32, "Int32";
    fmi3GetUInt32, fmi3SetUInt32, u32, "UInt32";
    fmi3GetInt64, fmi3SetInt64, i64, "Int64";
    fmi3GetUInt64, fmi3SetUInt64, u64, "UInt64";
    fmi3GetBoolean, fmi3SetBoolean, Fmi3Boolean, "Boolean";
    fmi3GetString, fmi3SetString, Fmi3String, "String";
}

/// `fmi3GetBinary` (no Binary variables).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetBinary(
    instance: Fmi3Instance,
    _value_references: *const Fmi3ValueReference,
    n_value_references: usize,
    _value_sizes: *mut usize,
    _values: *mut Fmi3Binary,
    _n_values: usize,
) -> Fmi3Status {
    call(instance, "fmi3GetBinary", |_| {
        no_such("Binary", n_value_references)
    })
}

/// `fmi3SetBinary` (no Binary variables).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetBinary(
    instance: Fmi3Instance,
    _value_references: *const Fmi3ValueReference,
    n_value_references: usize,
    _value_sizes: *const usize,
    _values: *const Fmi3Binary,
    _n_values: usize,
) -> Fmi3Status {
    call(instance, "fmi3SetBinary", |_| {
        no_such("Binary", n_value_references)
    })
}

/// `fmi3GetClock` (no clocks).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetClock(
    instance: Fmi3Instance,
    _value_references: *const Fmi3ValueReference,
    n_value_references: usize,
    _values: *mut Fmi3Clock,
) -> Fmi3Status {
    call(instance, "fmi3GetClock", |_| {
        no_such("Clock", n_value_references)
    })
}

/// `fmi3SetClock` (no clocks).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetClock(
    instance: Fmi3Instance,
    _value_references: *const Fmi3ValueReference,
    n_value_references: usize,
    _values: *const Fmi3Clock,
) -> Fmi3Status {
    call(instance, "fmi3SetClock", |_| {
        no_such("Clock", n_value_references)
    })
}

/// `fmi3GetFMUState`.
///
/// # Safety
/// See the module docs; `state` points to NULL or to a state from this FMU.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetFMUState(
    instance: Fmi3Instance,
    state: *mut Fmi3FmuState,
) -> Fmi3Status {
    // SAFETY: `state` as the standard prescribes (module docs; NULL detected).
    call(instance, "fmi3GetFMUState", |i| unsafe {
        get_state(i, state)
    })
}

/// `fmi3SetFMUState`.
///
/// # Safety
/// See the module docs; `state` was returned by `fmi3GetFMUState` of this FMU.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetFMUState(
    instance: Fmi3Instance,
    state: Fmi3FmuState,
) -> Fmi3Status {
    // SAFETY: `state` NULL or from fmi3GetFMUState of this FMU (module docs).
    call(instance, "fmi3SetFMUState", |i| unsafe {
        set_state(i, state)
    })
}

/// `fmi3FreeFMUState`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3FreeFMUState(
    instance: Fmi3Instance,
    state: *mut Fmi3FmuState,
) -> Fmi3Status {
    // SAFETY: `state` as the standard prescribes (module docs; NULL detected).
    call(instance, "fmi3FreeFMUState", |_| unsafe {
        free_state(state)
    })
}

/// `fmi3SerializedFMUStateSize`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3SerializedFMUStateSize(
    instance: Fmi3Instance,
    state: Fmi3FmuState,
    size: *mut usize,
) -> Fmi3Status {
    // SAFETY: `state` of this FMU, `size` writable (module docs; NULL detected).
    call(instance, "fmi3SerializedFMUStateSize", |_| unsafe {
        state_size(state, size)
    })
}

/// `fmi3SerializeFMUState`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3SerializeFMUState(
    instance: Fmi3Instance,
    state: Fmi3FmuState,
    serialized_state: *mut Fmi3Byte,
    size: usize,
) -> Fmi3Status {
    // SAFETY: `state` of this FMU, buffer valid for `size` (module docs; NULL detected).
    call(instance, "fmi3SerializeFMUState", |_| unsafe {
        serialize_state(state, serialized_state, size)
    })
}

/// `fmi3DeserializeFMUState`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi3DeserializeFMUState(
    instance: Fmi3Instance,
    serialized_state: *const Fmi3Byte,
    size: usize,
    state: *mut Fmi3FmuState,
) -> Fmi3Status {
    // SAFETY: buffer valid for `size`, `state` a slot (module docs; NULL detected).
    call(instance, "fmi3DeserializeFMUState", |_| unsafe {
        deserialize_state(serialized_state, size, state)
    })
}

/// `fmi3DoStep`: never an event, never early, never terminating; `lastSuccessfulTime`
/// is the time reached (the current time when the step failed).
///
/// # Safety
/// See the module docs; the four out pointers are NULL (not written) or writable.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn fmi3DoStep(
    instance: Fmi3Instance,
    current_communication_point: Fmi3Float64,
    communication_step_size: Fmi3Float64,
    _no_set_fmu_state_prior_to_current_point: Fmi3Boolean,
    event_handling_needed: *mut Fmi3Boolean,
    terminate_simulation: *mut Fmi3Boolean,
    early_return: *mut Fmi3Boolean,
    last_successful_time: *mut Fmi3Float64,
) -> Fmi3Status {
    call(instance, "fmi3DoStep", |i| {
        for flag in [event_handling_needed, terminate_simulation, early_return] {
            if !flag.is_null() {
                // SAFETY: a non-null out pointer is writable (module docs).
                unsafe { *flag = false };
            }
        }
        let res = i
            .slave
            .do_step(current_communication_point, communication_step_size);
        if !last_successful_time.is_null() {
            // SAFETY: as above.
            unsafe { *last_successful_time = i.slave.time() };
        }
        res?;
        Ok(i.warn())
    })
}

/// Functions of the standard this FMU does not support: exported (an importer may look
/// them all up), each returning `fmi3Error` with the reason logged.
macro_rules! unsupported {
    ($($name:ident ( $($arg:ident : $ty:ty),* ) => $why:literal;)*) => {$(
        #[doc = concat!("`", stringify!($name), "`: not supported (", $why, ").")]
        ///
        /// # Safety
        /// See the module docs.
        #[no_mangle]
        pub unsafe extern "C" fn $name(instance: Fmi3Instance $(, $arg: $ty)*) -> Fmi3Status {
            $(let _ = $arg;)*
            call(instance, stringify!($name), |_| Err(format!("not supported: {}", $why)))
        }
    )*};
}

unsupported! {
    fmi3EnterEventMode() => "the FMU has no event mode (hasEventMode is false)";
    fmi3EnterStepMode() =>
        "the FMU has no event mode: it is in Step Mode right after fmi3ExitInitializationMode";
    fmi3EvaluateDiscreteStates() => "the FMU has no discrete states";
    fmi3UpdateDiscreteStates(
        discrete_states_need_update: *mut Fmi3Boolean,
        terminate_simulation: *mut Fmi3Boolean,
        nominals_of_continuous_states_changed: *mut Fmi3Boolean,
        values_of_continuous_states_changed: *mut Fmi3Boolean,
        next_event_time_defined: *mut Fmi3Boolean,
        next_event_time: *mut Fmi3Float64
    ) => "the FMU has no event mode";
    fmi3EnterConfigurationMode() => "the FMU has no structural parameters";
    fmi3ExitConfigurationMode() => "the FMU has no structural parameters";
    fmi3GetNumberOfVariableDependencies(
        value_reference: Fmi3ValueReference,
        n_dependencies: *mut usize
    ) => "providesPerElementDependencies is false; ModelStructure lists the dependencies";
    fmi3GetVariableDependencies(
        dependent: Fmi3ValueReference,
        element_indices_of_dependent: *mut usize,
        independents: *mut Fmi3ValueReference,
        element_indices_of_independents: *mut usize,
        dependency_kinds: *mut Fmi3DependencyKind,
        n_dependencies: usize
    ) => "providesPerElementDependencies is false; ModelStructure lists the dependencies";
    fmi3GetDirectionalDerivative(
        unknowns: *const Fmi3ValueReference,
        n_unknowns: usize,
        knowns: *const Fmi3ValueReference,
        n_knowns: usize,
        seed: *const Fmi3Float64,
        n_seed: usize,
        sensitivity: *mut Fmi3Float64,
        n_sensitivity: usize
    ) => "providesDirectionalDerivatives is false";
    fmi3GetAdjointDerivative(
        unknowns: *const Fmi3ValueReference,
        n_unknowns: usize,
        knowns: *const Fmi3ValueReference,
        n_knowns: usize,
        seed: *const Fmi3Float64,
        n_seed: usize,
        sensitivity: *mut Fmi3Float64,
        n_sensitivity: usize
    ) => "providesAdjointDerivatives is false";
    fmi3GetOutputDerivatives(
        value_references: *const Fmi3ValueReference,
        n_value_references: usize,
        orders: *const i32,
        values: *mut Fmi3Float64,
        n_values: usize
    ) => "maxOutputDerivativeOrder is 0";
    fmi3GetIntervalDecimal(
        value_references: *const Fmi3ValueReference,
        n_value_references: usize,
        intervals: *mut Fmi3Float64,
        qualifiers: *mut Fmi3IntervalQualifier
    ) => "the FMU has no clocks";
    fmi3GetIntervalFraction(
        value_references: *const Fmi3ValueReference,
        n_value_references: usize,
        counters: *mut u64,
        resolutions: *mut u64,
        qualifiers: *mut Fmi3IntervalQualifier
    ) => "the FMU has no clocks";
    fmi3GetShiftDecimal(
        value_references: *const Fmi3ValueReference,
        n_value_references: usize,
        shifts: *mut Fmi3Float64
    ) => "the FMU has no clocks";
    fmi3GetShiftFraction(
        value_references: *const Fmi3ValueReference,
        n_value_references: usize,
        counters: *mut u64,
        resolutions: *mut u64
    ) => "the FMU has no clocks";
    fmi3SetIntervalDecimal(
        value_references: *const Fmi3ValueReference,
        n_value_references: usize,
        intervals: *const Fmi3Float64
    ) => "the FMU has no clocks";
    fmi3SetIntervalFraction(
        value_references: *const Fmi3ValueReference,
        n_value_references: usize,
        counters: *const u64,
        resolutions: *const u64
    ) => "the FMU has no clocks";
    fmi3SetShiftDecimal(
        value_references: *const Fmi3ValueReference,
        n_value_references: usize,
        shifts: *const Fmi3Float64
    ) => "the FMU has no clocks";
    fmi3SetShiftFraction(
        value_references: *const Fmi3ValueReference,
        n_value_references: usize,
        counters: *const u64,
        resolutions: *const u64
    ) => "the FMU has no clocks";
    fmi3ActivateModelPartition(
        clock_reference: Fmi3ValueReference,
        activation_time: Fmi3Float64
    ) => "Scheduled Execution is not supported";
    fmi3EnterContinuousTimeMode() => "Model Exchange is not supported";
    fmi3CompletedIntegratorStep(
        no_set_fmu_state_prior_to_current_point: Fmi3Boolean,
        enter_event_mode: *mut Fmi3Boolean,
        terminate_simulation: *mut Fmi3Boolean
    ) => "Model Exchange is not supported";
    fmi3SetTime(time: Fmi3Float64) => "Model Exchange is not supported";
    fmi3SetContinuousStates(
        continuous_states: *const Fmi3Float64,
        n_continuous_states: usize
    ) => "Model Exchange is not supported";
    fmi3GetContinuousStateDerivatives(
        derivatives: *mut Fmi3Float64,
        n_continuous_states: usize
    ) => "Model Exchange is not supported";
    fmi3GetEventIndicators(
        event_indicators: *mut Fmi3Float64,
        n_event_indicators: usize
    ) => "Model Exchange is not supported";
    fmi3GetContinuousStates(
        continuous_states: *mut Fmi3Float64,
        n_continuous_states: usize
    ) => "Model Exchange is not supported";
    fmi3GetNominalsOfContinuousStates(
        nominals: *mut Fmi3Float64,
        n_continuous_states: usize
    ) => "Model Exchange is not supported";
    fmi3GetNumberOfEventIndicators(n_event_indicators: *mut usize) =>
        "Model Exchange is not supported";
    fmi3GetNumberOfContinuousStates(n_continuous_states: *mut usize) =>
        "Model Exchange is not supported";
}
