//! FMI 2.0 and FMI 3.0 C types (hand-written from `fmi2TypesPlatform.h` /
//! `fmi2FunctionTypes.h` and `fmi3PlatformTypes.h` / `fmi3FunctionTypes.h`).

use std::ffi::{c_char, c_int, c_void};

/// `fmi2Component`: the instance pointer handed to the importer.
pub type Fmi2Component = *mut c_void;
/// `fmi2ComponentEnvironment`.
pub type Fmi2ComponentEnvironment = *mut c_void;
/// `fmi2FMUstate`.
pub type Fmi2FmuState = *mut c_void;
/// `fmi2ValueReference`.
pub type Fmi2ValueReference = u32;
/// `fmi2Real`.
pub type Fmi2Real = f64;
/// `fmi2Integer`.
pub type Fmi2Integer = c_int;
/// `fmi2Boolean` (0 = false).
pub type Fmi2Boolean = c_int;
/// `fmi2String`.
pub type Fmi2String = *const c_char;
/// `fmi2Byte`.
pub type Fmi2Byte = c_char;

/// `fmi2Status`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(dead_code)]
pub enum Fmi2Status {
    /// fmi2OK
    Ok = 0,
    /// fmi2Warning
    Warning = 1,
    /// fmi2Discard (never returned by this slave)
    Discard = 2,
    /// fmi2Error
    Error = 3,
    /// fmi2Fatal
    Fatal = 4,
    /// fmi2Pending
    Pending = 5,
}

/// `fmi2Type`: 0 = ModelExchange, 1 = CoSimulation.
pub type Fmi2Type = c_int;
/// `fmi2StatusKind`: 0 DoStepStatus, 1 PendingStatus, 2 LastSuccessfulTime, 3 Terminated.
pub type Fmi2StatusKind = c_int;

/// The logger callback (C variadic).
pub type Fmi2CallbackLogger = Option<
    unsafe extern "C" fn(
        Fmi2ComponentEnvironment,
        Fmi2String,
        Fmi2Status,
        Fmi2String,
        Fmi2String,
        ...
    ),
>;

/// `fmi2CallbackFunctions`.
#[repr(C)]
#[derive(Debug)]
pub struct Fmi2CallbackFunctions {
    /// Logger.
    pub logger: Fmi2CallbackLogger,
    /// calloc-like allocator (unused: canNotUseMemoryManagementFunctions).
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    /// free-like deallocator (unused).
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    /// Asynchronous step callback (unused).
    pub step_finished: Option<unsafe extern "C" fn(Fmi2ComponentEnvironment, Fmi2Status)>,
    /// Passed back to the logger.
    pub component_environment: Fmi2ComponentEnvironment,
}

// ---------------------------------------------------------------------------------------
// FMI 3.0 (hand-written from `fmi3PlatformTypes.h` / `fmi3FunctionTypes.h`)
// ---------------------------------------------------------------------------------------

/// `fmi3Instance`: the instance pointer handed to the importer.
pub type Fmi3Instance = *mut c_void;
/// `fmi3InstanceEnvironment`.
pub type Fmi3InstanceEnvironment = *mut c_void;
/// `fmi3FMUState`.
pub type Fmi3FmuState = *mut c_void;
/// `fmi3ValueReference`.
pub type Fmi3ValueReference = u32;
/// `fmi3Float64`.
pub type Fmi3Float64 = f64;
/// `fmi3Boolean` (C99 `bool`).
pub type Fmi3Boolean = bool;
/// `fmi3Byte`.
pub type Fmi3Byte = u8;
/// `fmi3Binary`.
pub type Fmi3Binary = *const u8;
/// `fmi3Clock` (C99 `bool`).
pub type Fmi3Clock = bool;
/// `fmi3String`.
pub type Fmi3String = *const c_char;
/// `fmi3DependencyKind` (C enum).
pub type Fmi3DependencyKind = c_int;
/// `fmi3IntervalQualifier` (C enum).
pub type Fmi3IntervalQualifier = c_int;

/// `fmi3Status` (the same numbers as [`Fmi2Status`], without `Pending`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(dead_code)]
pub enum Fmi3Status {
    /// fmi3OK
    Ok = 0,
    /// fmi3Warning
    Warning = 1,
    /// fmi3Discard (never returned by this slave)
    Discard = 2,
    /// fmi3Error
    Error = 3,
    /// fmi3Fatal
    Fatal = 4,
}

/// `fmi3LogMessageCallback`.
pub type Fmi3LogMessageCallback =
    Option<unsafe extern "C" fn(Fmi3InstanceEnvironment, Fmi3Status, Fmi3String, Fmi3String)>;

/// `fmi3IntermediateUpdateCallback` (never called: `providesIntermediateUpdate` is false).
pub type Fmi3IntermediateUpdateCallback = Option<
    unsafe extern "C" fn(
        Fmi3InstanceEnvironment,
        Fmi3Float64,
        Fmi3Boolean,
        Fmi3Boolean,
        Fmi3Boolean,
        Fmi3Boolean,
        *mut Fmi3Boolean,
        *mut Fmi3Float64,
    ),
>;

/// `fmi3ClockUpdateCallback` (Scheduled Execution: not supported).
pub type Fmi3ClockUpdateCallback = Option<unsafe extern "C" fn(Fmi3InstanceEnvironment)>;

/// `fmi3LockPreemptionCallback` / `fmi3UnlockPreemptionCallback` (Scheduled Execution: not
/// supported).
pub type Fmi3PreemptionCallback = Option<unsafe extern "C" fn()>;
