//! What the FMI 2.0 and FMI 3.0 exports share: the instance handed to the importer, its
//! logger, the one trampoline every exported function runs in ([`call`]), the pointer
//! helpers, instantiation from the resources and the FMU state functions. Both sets of
//! exports drive the same [`Slave`]; only their C signatures differ.
//!
//! The trampoline: NULL instance → error; an instance that panicked earlier → error (it
//! is poisoned: only `FreeInstance` is left to do); otherwise the body runs inside
//! `catch_unwind`, `Err(msg)` → error status with `msg` logged, a panic → fatal status
//! with a logged message, and the instance poisoned.

use crate::ffi::*;
use crate::model::Model;
use crate::slave::Snapshot;
use std::ffi::{c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

/// The FMI version of an instance (which logger, which words in messages).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Api {
    Fmi2,
    Fmi3,
}

impl Api {
    /// The name of the token the importer passes at instantiation.
    fn token_name(self) -> &'static str {
        match self {
            Api::Fmi2 => "GUID",
            Api::Fmi3 => "instantiationToken",
        }
    }
}

/// A status independent of the FMI version (the numbers of `fmi2Status`/`fmi3Status`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Status {
    Ok,
    Warning,
    Error,
    Fatal,
}

impl From<Status> for Fmi2Status {
    fn from(s: Status) -> Self {
        match s {
            Status::Ok => Fmi2Status::Ok,
            Status::Warning => Fmi2Status::Warning,
            Status::Error => Fmi2Status::Error,
            Status::Fatal => Fmi2Status::Fatal,
        }
    }
}

impl From<Status> for Fmi3Status {
    fn from(s: Status) -> Self {
        match s {
            Status::Ok => Fmi3Status::Ok,
            Status::Warning => Fmi3Status::Warning,
            Status::Error => Fmi3Status::Error,
            Status::Fatal => Fmi3Status::Fatal,
        }
    }
}

/// The importer's logger, as each FMI version passes it.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Logger {
    Fmi2(Fmi2CallbackLogger, Fmi2ComponentEnvironment),
    Fmi3(Fmi3LogMessageCallback, Fmi3InstanceEnvironment),
}

impl Logger {
    /// Hands `msg` to the importer (nothing when it gave no logger).
    pub(crate) fn log(&self, name: &CStr, status: Status, category: &str, msg: &str) {
        let cat = CString::new(category).unwrap_or_default();
        let m = CString::new(msg.replace('\0', " ")).unwrap_or_default();
        match *self {
            Logger::Fmi2(Some(f), env) => {
                // SAFETY: the logger is the importer's callback; every string is
                // NUL-terminated and outlives the call; "%s" consumes exactly one string.
                unsafe {
                    f(
                        env,
                        name.as_ptr(),
                        status.into(),
                        cat.as_ptr(),
                        c"%s".as_ptr(),
                        m.as_ptr(),
                    )
                };
            }
            Logger::Fmi3(Some(f), env) => {
                // SAFETY: the importer's callback; NUL-terminated strings that outlive it.
                unsafe { f(env, status.into(), cat.as_ptr(), m.as_ptr()) };
            }
            _ => {}
        }
    }
}

/// One instance as handed to the importer (`fmi2Component` / `fmi3Instance`).
#[derive(Debug)]
pub(crate) struct Instance {
    pub(crate) name: CString,
    pub(crate) logger: Logger,
    pub(crate) debug: bool,
    /// Set when a call panicked: every later call is refused.
    pub(crate) poisoned: bool,
    pub(crate) slave: Model,
}

impl Instance {
    pub(crate) fn new(name: CString, logger: Logger, debug: bool, slave: Model) -> Self {
        Instance {
            name,
            logger,
            debug,
            poisoned: false,
            slave,
        }
    }

    pub(crate) fn log(&self, status: Status, msg: &str) {
        let cat = match status {
            Status::Ok => "logAll",
            Status::Warning => "logStatusWarning",
            _ => "logStatusError",
        };
        if status != Status::Ok || self.debug {
            self.logger.log(&self.name, status, cat, msg);
        }
    }

    /// Logs the slave's pending warnings (a pose leaving the measured box): a warning
    /// status when there were any, else OK.
    pub(crate) fn warn(&mut self) -> Status {
        let w = self.slave.take_warnings();
        for m in &w {
            self.log(Status::Warning, m);
        }
        if w.is_empty() {
            Status::Ok
        } else {
            Status::Warning
        }
    }
}

/// The one place a panic is caught: `f()`, or `on_panic` if it panicked (no unwinding
/// across the C boundary). Generic over the return value (a status, an instance pointer,
/// nothing), so instantiation and freeing run inside it too; [`call`] builds on it.
pub(crate) fn guard<R>(on_panic: R, f: impl FnOnce() -> R) -> R {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or(on_panic)
}

/// The trampoline: every exported function's body runs inside it (module docs).
pub(crate) fn call<S: From<Status>>(
    c: *mut c_void,
    what: &str,
    f: impl FnOnce(&mut Instance) -> Result<Status, String>,
) -> S {
    if c.is_null() {
        return Status::Error.into();
    }
    // SAFETY: non-null `c` was created by an instantiate function (Box::into_raw) and is
    // only freed by a FreeInstance; the importer does not call one instance concurrently.
    let inst = unsafe { &mut *(c as *mut Instance) };
    if inst.poisoned {
        inst.log(
            Status::Error,
            &format!(
                "{what}: refused: an earlier call on this instance failed with an internal \
                 error (panic); free the instance and instantiate a new one"
            ),
        );
        return Status::Error.into();
    }
    let status = match guard(None, || Some(f(inst))) {
        Some(Ok(s)) => s,
        Some(Err(msg)) => {
            inst.log(Status::Error, &format!("{what}: {msg}"));
            Status::Error
        }
        None => {
            inst.poisoned = true;
            inst.log(Status::Fatal, &format!("{what}: internal error (panic)"));
            Status::Fatal
        }
    };
    status.into()
}

/// Frees an instance made by [`into_raw`] (NULL: nothing).
///
/// # Safety
/// `c` is NULL or came from [`into_raw`] and is freed once.
pub(crate) unsafe fn free(c: *mut c_void) {
    if !c.is_null() {
        // SAFETY: `c` came from Box::into_raw in `into_raw` and is freed once.
        let inst = unsafe { Box::from_raw(c as *mut Instance) };
        guard((), || drop(inst));
    }
}

/// The pointer handed to the importer.
pub(crate) fn into_raw(i: Instance) -> *mut c_void {
    Box::into_raw(Box::new(i)) as *mut c_void
}

/// `(ptr, n)` → slice; NULL with `n == 0` → empty; NULL with `n > 0` → error.
///
/// # Safety
/// A non-null `p` must be valid for `n` reads.
pub(crate) unsafe fn slice<'a, T>(p: *const T, n: usize, what: &str) -> Result<&'a [T], String> {
    if n == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err(format!(
            "{what} is NULL but {} announced",
            if n == 1 {
                "1 value was".to_string()
            } else {
                format!("{n} values were")
            }
        ));
    }
    // SAFETY: non-null and valid for n elements per the caller's contract.
    Ok(unsafe { std::slice::from_raw_parts(p, n) })
}

/// Mutable version of [`slice`].
///
/// # Safety
/// A non-null `p` must be valid for `n` writes.
pub(crate) unsafe fn slice_mut<'a, T>(
    p: *mut T,
    n: usize,
    what: &str,
) -> Result<&'a mut [T], String> {
    if n == 0 {
        return Ok(&mut []);
    }
    if p.is_null() {
        return Err(format!(
            "{what} is NULL but {} announced",
            if n == 1 {
                "1 value was".to_string()
            } else {
                format!("{n} values were")
            }
        ));
    }
    // SAFETY: non-null and valid for n elements per the caller's contract.
    Ok(unsafe { std::slice::from_raw_parts_mut(p, n) })
}

/// # Safety
/// `s` is NULL or NUL-terminated.
pub(crate) unsafe fn string(s: *const std::ffi::c_char) -> Option<String> {
    if s.is_null() {
        return None;
    }
    // SAFETY: non-null, NUL-terminated per the caller's contract.
    Some(unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned())
}

fn percent_decode(s: &str) -> Result<String, String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = s
                .get(i + 1..i + 3)
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("bad percent-encoding in '{s}'"))?;
            out.push(hex);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| format!("resource location '{s}' is not UTF-8"))
}

/// The resources folder from `fmuResourceLocation` (`file:///p`, `file:/p`,
/// `file://localhost/p`, percent-encoded, with or without trailing slash, or a plain
/// path).
pub fn resource_dir(loc: &str) -> Result<PathBuf, String> {
    let rest = if let Some(r) = loc.strip_prefix("file://") {
        if let Some(r2) = r.strip_prefix("localhost") {
            r2.to_string()
        } else if r.starts_with('/') {
            r.to_string()
        } else {
            return Err(format!("resource location '{loc}' names a remote host"));
        }
    } else if let Some(r) = loc.strip_prefix("file:") {
        r.to_string()
    } else {
        loc.to_string()
    };
    let p = percent_decode(&rest)?;
    Ok(PathBuf::from(p.trim_end_matches('/').to_string() + "/"))
}

/// The model in `dir` (the twin, or the milling process of a process FMU), after
/// checking the importer's token (the GUID or instantiation token) against its resources.
pub(crate) fn load_slave(
    api: Api,
    name: &str,
    token: Option<String>,
    dir: PathBuf,
) -> Result<Model, String> {
    Model::load(&dir, name, token, api.token_name())
}

/// The getters and setters of a type this FMU has no variables of: fine for none.
pub(crate) fn no_such(kind: &str, nvr: usize) -> Result<Status, String> {
    if nvr == 0 {
        Ok(Status::Ok)
    } else {
        Err(format!("this FMU has no {kind} variables"))
    }
}

/// `GetFMUstate` of both versions: a new state in a NULL slot, else overwritten.
///
/// # Safety
/// `state` is NULL or points to a slot holding NULL or a state of this FMU.
pub(crate) unsafe fn get_state(
    i: &mut Instance,
    state: *mut *mut c_void,
) -> Result<Status, String> {
    if state.is_null() {
        return Err("FMUstate pointer is NULL".into());
    }
    let snap = i.slave.snapshot()?;
    // SAFETY: `state` is a valid pointer to an FMUstate slot (checked non-null).
    let slot = unsafe { &mut *state };
    if slot.is_null() {
        *slot = Box::into_raw(Box::new(snap)) as *mut c_void;
    } else {
        // SAFETY: a non-null slot holds a Snapshot this FMU allocated.
        unsafe { *(*slot as *mut Snapshot) = snap };
    }
    Ok(Status::Ok)
}

/// `SetFMUstate` of both versions.
///
/// # Safety
/// `state` is NULL or a state of this FMU.
pub(crate) unsafe fn set_state(i: &mut Instance, state: *mut c_void) -> Result<Status, String> {
    if state.is_null() {
        return Err("FMUstate is NULL".into());
    }
    // SAFETY: a non-null state is a Snapshot this FMU allocated.
    let s = unsafe { &*(state as *const Snapshot) };
    i.slave.restore(s).map(|_| Status::Ok)
}

/// `FreeFMUstate` of both versions (a NULL pointer or slot: nothing to free).
///
/// # Safety
/// `state` is NULL or points to a slot holding NULL or a state of this FMU.
pub(crate) unsafe fn free_state(state: *mut *mut c_void) -> Result<Status, String> {
    if state.is_null() {
        return Ok(Status::Ok);
    }
    // SAFETY: valid pointer to a state slot (checked non-null).
    let slot = unsafe { &mut *state };
    if !slot.is_null() {
        // SAFETY: the slot holds a Snapshot allocated by get_state; freed once.
        drop(unsafe { Box::from_raw(*slot as *mut Snapshot) });
        *slot = std::ptr::null_mut();
    }
    Ok(Status::Ok)
}

/// `SerializedFMUstateSize` of both versions.
///
/// # Safety
/// `state` is NULL or a state of this FMU; `size` NULL or writable.
pub(crate) unsafe fn state_size(state: *mut c_void, size: *mut usize) -> Result<Status, String> {
    if state.is_null() || size.is_null() {
        return Err("FMUstate or size is NULL".into());
    }
    // SAFETY: a Snapshot of this FMU (non-null).
    let s = unsafe { &*(state as *const Snapshot) };
    // SAFETY: non-null out pointer.
    unsafe { *size = s.to_bytes().len() };
    Ok(Status::Ok)
}

/// `SerializeFMUstate` of both versions.
///
/// # Safety
/// `state` is NULL or a state of this FMU; `bytes` NULL or valid for `size` writes.
pub(crate) unsafe fn serialize_state(
    state: *mut c_void,
    bytes: *mut u8,
    size: usize,
) -> Result<Status, String> {
    if state.is_null() {
        return Err("FMUstate is NULL".into());
    }
    // SAFETY: a Snapshot of this FMU (non-null).
    let s = unsafe { &*(state as *const Snapshot) };
    let b = s.to_bytes();
    if size < b.len() {
        return Err(format!(
            "buffer of {size} bytes is too small ({} needed)",
            b.len()
        ));
    }
    // SAFETY: buffer valid for `size` bytes (NULL detected).
    let out = unsafe { slice_mut(bytes, b.len(), "serializedState") }?;
    out.copy_from_slice(&b);
    Ok(Status::Ok)
}

/// `DeSerializeFMUstate` of both versions: always a new state (a state in the slot is
/// freed).
///
/// # Safety
/// `bytes` NULL or valid for `size` reads; `state` NULL or a slot holding NULL or a state
/// of this FMU.
pub(crate) unsafe fn deserialize_state(
    bytes: *const u8,
    size: usize,
    state: *mut *mut c_void,
) -> Result<Status, String> {
    if state.is_null() {
        return Err("FMUstate pointer is NULL".into());
    }
    // SAFETY: buffer valid for `size` bytes (NULL detected).
    let b = unsafe { slice(bytes, size, "serializedState") }?;
    let snap = Snapshot::from_bytes(b)?;
    // SAFETY: valid slot pointer (checked non-null).
    let slot = unsafe { &mut *state };
    if !slot.is_null() {
        // SAFETY: a non-null slot holds a Snapshot of this FMU; replaced.
        drop(unsafe { Box::from_raw(*slot as *mut Snapshot) });
    }
    *slot = Box::into_raw(Box::new(snap)) as *mut c_void;
    Ok(Status::Ok)
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtwin_core::axis::Axis;
    use vmachine::structure::ModalMachine;

    /// A call that panics returns the fatal status and poisons the instance: every later
    /// call on it returns an error (and logs why), for both FMI versions.
    #[test]
    fn a_panic_poisons_the_instance() {
        let twin = ModalMachine::default_machine().exact_twin([2, 1, 1], &[Axis::X]);
        for logger in [
            Logger::Fmi2(None, std::ptr::null_mut()),
            Logger::Fmi3(None, std::ptr::null_mut()),
        ] {
            let slave = Model::Twin(Box::new(crate::slave::Slave::new(&twin).unwrap()));
            let c = into_raw(Instance::new(c"t".into(), logger, false, slave));
            let ok: Fmi3Status = call(c, "ok", |_| Ok(Status::Ok));
            assert_eq!(ok, Fmi3Status::Ok);
            let fatal: Fmi2Status = call(c, "boom", |_| panic!("injected panic (expected)"));
            assert_eq!(fatal, Fmi2Status::Fatal);
            let mut ran = false;
            let after: Fmi3Status = call(c, "after", |_| {
                ran = true;
                Ok(Status::Ok)
            });
            assert_eq!(after, Fmi3Status::Error);
            assert!(!ran, "a poisoned instance must not run the call");
            // SAFETY: made by into_raw above, freed once.
            unsafe { free(c) };
        }
    }
}
