//! The built shared library through its C API, loaded with libloading (as an importer
//! would): life cycle, NULL pointers, unknown references, and a seeded random sequence of
//! calls in any order — every call returns a status, none crashes the host. Both the
//! FMI 2.0 and the FMI 3.0 functions.
//!
//! `MTWIN_FUZZ_CALLS` (default 20000) sets the number of random calls and
//! `MTWIN_FUZZ_SEED` (default a fixed seed) the seed; `scripts/fuzz.sh` raises both.

use libloading::{Library, Symbol};
use mtwin_core::axis::Axis;
use mtwin_core::twin::Twin;
use std::ffi::{c_char, c_int, c_void, CString};
use std::path::PathBuf;
use vmachine::structure::ModalMachine;

type Comp = *mut c_void;

fn lib_path() -> PathBuf {
    let exe = std::env::current_exe().expect("exe");
    let deps = exe.parent().expect("deps").to_path_buf();
    for d in [deps.clone(), deps.parent().expect("profile").to_path_buf()] {
        let p = d.join("libmtwin_fmu.so");
        if p.is_file() {
            return p;
        }
    }
    panic!("libmtwin_fmu.so not found near {}", deps.display());
}

fn twin_dir() -> (tempfile::TempDir, Twin) {
    let twin = ModalMachine::default_machine().exact_twin([2, 2, 1], &[Axis::X, Axis::Y]);
    let d = tempfile::tempdir().expect("tmp");
    let res = d.path().join("res dir ü");
    std::fs::create_dir_all(&res).expect("mkdir");
    twin.save(&res.join("twin.json")).expect("save");
    (d, twin)
}

/// `MTWIN_FUZZ_CALLS` and `MTWIN_FUZZ_SEED` (decimal or `0x` hex), with defaults.
fn fuzz_settings() -> (u64, u64) {
    let num = |name: &str| {
        std::env::var(name).ok().and_then(|s| {
            let s = s.trim();
            match s.strip_prefix("0x") {
                Some(h) => u64::from_str_radix(h, 16).ok(),
                None => s.parse().ok(),
            }
        })
    };
    let calls = num("MTWIN_FUZZ_CALLS").unwrap_or(20_000);
    // xorshift needs a non-zero state
    let seed = num("MTWIN_FUZZ_SEED")
        .filter(|&s| s != 0)
        .unwrap_or(0x2545_F491_4F6C_DD1D);
    (calls, seed)
}

#[test]
fn c_api_survives_misuse_and_random_call_sequences() {
    let (d, twin) = twin_dir();
    let loc = format!(
        "file://{}/res%20dir%20%C3%BC/",
        d.path().display().to_string().replace(' ', "%20")
    );
    // SAFETY: loading our own library built by cargo; its initialisers are trivial.
    let lib = unsafe { Library::new(lib_path()) }.expect("load");
    type Inst = unsafe extern "C" fn(
        *const c_char,
        c_int,
        *const c_char,
        *const c_char,
        *const c_void,
        c_int,
        c_int,
    ) -> Comp;
    type Free = unsafe extern "C" fn(Comp);
    type Simple = unsafe extern "C" fn(Comp) -> c_int;
    type Setup = unsafe extern "C" fn(Comp, c_int, f64, f64, c_int, f64) -> c_int;
    type GetR = unsafe extern "C" fn(Comp, *const u32, usize, *mut f64) -> c_int;
    type SetR = unsafe extern "C" fn(Comp, *const u32, usize, *const f64) -> c_int;
    type Step = unsafe extern "C" fn(Comp, f64, f64, c_int) -> c_int;
    type GetS = unsafe extern "C" fn(Comp, *mut *mut c_void) -> c_int;
    type SetS = unsafe extern "C" fn(Comp, *mut c_void) -> c_int;
    type SizeS = unsafe extern "C" fn(Comp, *mut c_void, *mut usize) -> c_int;
    type SerS = unsafe extern "C" fn(Comp, *mut c_void, *mut u8, usize) -> c_int;
    type DeS = unsafe extern "C" fn(Comp, *const u8, usize, *mut *mut c_void) -> c_int;
    // SAFETY: the symbols have exactly these FMI 2.0 signatures.
    unsafe {
        let inst: Symbol<Inst> = lib.get(b"fmi2Instantiate").expect("sym");
        let free: Symbol<Free> = lib.get(b"fmi2FreeInstance").expect("sym");
        let setup: Symbol<Setup> = lib.get(b"fmi2SetupExperiment").expect("sym");
        let enter: Symbol<Simple> = lib.get(b"fmi2EnterInitializationMode").expect("sym");
        let exit: Symbol<Simple> = lib.get(b"fmi2ExitInitializationMode").expect("sym");
        let term: Symbol<Simple> = lib.get(b"fmi2Terminate").expect("sym");
        let reset: Symbol<Simple> = lib.get(b"fmi2Reset").expect("sym");
        let get: Symbol<GetR> = lib.get(b"fmi2GetReal").expect("sym");
        let set: Symbol<SetR> = lib.get(b"fmi2SetReal").expect("sym");
        let step: Symbol<Step> = lib.get(b"fmi2DoStep").expect("sym");
        let get_s: Symbol<GetS> = lib.get(b"fmi2GetFMUstate").expect("sym");
        let set_s: Symbol<SetS> = lib.get(b"fmi2SetFMUstate").expect("sym");
        let free_s: Symbol<GetS> = lib.get(b"fmi2FreeFMUstate").expect("sym");
        let size_s: Symbol<SizeS> = lib.get(b"fmi2SerializedFMUstateSize").expect("sym");
        let ser_s: Symbol<SerS> = lib.get(b"fmi2SerializeFMUstate").expect("sym");
        let de_s: Symbol<DeS> = lib.get(b"fmi2DeSerializeFMUstate").expect("sym");
        let name = CString::new("t").unwrap();
        let guid = CString::new(twin.guid()).unwrap();
        let bad = CString::new("{bad}").unwrap();
        let cloc = CString::new(loc).unwrap();
        // wrong GUID, NULL location, model exchange: NULL instance
        assert!(inst(
            name.as_ptr(),
            1,
            bad.as_ptr(),
            cloc.as_ptr(),
            std::ptr::null(),
            0,
            0
        )
        .is_null());
        assert!(inst(
            name.as_ptr(),
            1,
            guid.as_ptr(),
            std::ptr::null(),
            std::ptr::null(),
            0,
            0
        )
        .is_null());
        assert!(inst(
            name.as_ptr(),
            0,
            guid.as_ptr(),
            cloc.as_ptr(),
            std::ptr::null(),
            0,
            0
        )
        .is_null());
        let c = inst(
            name.as_ptr(),
            1,
            guid.as_ptr(),
            cloc.as_ptr(),
            std::ptr::null(),
            0,
            0,
        );
        assert!(!c.is_null(), "percent-encoded path with a space and ü");
        // NULL component and NULL arrays
        assert_eq!(step(std::ptr::null_mut(), 0.0, 1e-3, 1), 3);
        assert_eq!(get(c, std::ptr::null(), 2, std::ptr::null_mut()), 3);
        assert_eq!(get(c, std::ptr::null(), 0, std::ptr::null_mut()), 0);
        // random sequences: any order, any values
        let (calls, mut seed) = fuzz_settings();
        let seed0 = seed;
        eprintln!("fuzz: {calls} random calls, seed {seed0:#x}");
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let mut t = 0.0;
        // FMU states this test holds (each freed exactly once), with their time when known
        let mut states: Vec<(*mut c_void, Option<f64>)> = Vec::new();
        // the last calls, shown when an assertion fails
        let mut recent: std::collections::VecDeque<String> = Default::default();
        for _ in 0..calls {
            let r = rnd();
            let vr = [(r >> 8) as u32 % 10];
            let v = [f64::from_bits(rnd()) * if r & 1 == 0 { 1.0 } else { 0.0 }
                + ((r >> 20) % 1000) as f64];
            let mut out = [0.0f64];
            let op = r % 13;
            let pick = ((r >> 40) as usize) % states.len().max(1);
            let st = match op {
                0 => setup(c, 0, 0.0, 0.0, 0, 0.0),
                1 => enter(c),
                2 => exit(c),
                3 => term(c),
                4 => reset(c),
                5 => get(c, vr.as_ptr(), 1, out.as_mut_ptr()),
                6 => set(c, vr.as_ptr(), 1, v.as_ptr()),
                7 => {
                    let h = ((r >> 32) % 100) as f64 * 1e-5;
                    let s = step(c, t, h, 1);
                    // fmi2Warning: the step went through (axes outside the measured box)
                    if s <= 1 {
                        t += h;
                    }
                    s
                }
                8 => step(c, f64::from_bits(rnd()), 1e-3, 1),
                // FMU states: get (into a new or an existing slot), set, free
                9 => {
                    if states.is_empty() || r & 2 == 0 {
                        let mut slot = std::ptr::null_mut();
                        let st = get_s(c, &mut slot);
                        if !slot.is_null() {
                            states.push((slot, Some(t)));
                        }
                        st
                    } else {
                        let st = get_s(c, &mut states[pick].0);
                        if st == 0 {
                            states[pick].1 = Some(t);
                        }
                        st
                    }
                }
                10 if !states.is_empty() => {
                    let st = set_s(c, states[pick].0);
                    if st == 0 {
                        t = states[pick].1.unwrap_or(f64::NAN);
                    }
                    st
                }
                11 if !states.is_empty() => {
                    let (mut p, _) = states.swap_remove(pick);
                    let st = free_s(c, &mut p);
                    assert!(p.is_null(), "freed state slot not cleared");
                    st
                }
                // serialize a state, corrupt the bytes, deserialize into a new state
                12 if !states.is_empty() => {
                    let mut n = 0usize;
                    let st = size_s(c, states[pick].0, &mut n);
                    assert_eq!(st, 0, "size of a valid state");
                    let mut buf = vec![0u8; n];
                    let st = ser_s(c, states[pick].0, buf.as_mut_ptr(), n);
                    assert_eq!(st, 0, "serialize a valid state");
                    let small = ser_s(c, states[pick].0, buf.as_mut_ptr(), n.saturating_sub(1));
                    assert_eq!(small, 3, "a short buffer is an error");
                    match (r >> 20) % 5 {
                        0 => {}
                        1 => {
                            let i = (rnd() as usize) % n.max(1);
                            buf[i] ^= 1 << (rnd() % 8);
                        }
                        2 => buf.truncate((rnd() as usize) % (n + 1)),
                        3 => buf.push(rnd() as u8),
                        _ => {
                            // a NaN, an infinity or garbage where a number is: the time (byte
                            // 8), the 6 inputs (17..65), the state (65..)
                            let k = (rnd() as usize) % (1 + (n.saturating_sub(17)) / 8).max(1);
                            let i = if k == 0 { 8 } else { 17 + 8 * (k - 1) };
                            let bad = [
                                f64::NAN,
                                f64::INFINITY,
                                -f64::INFINITY,
                                f64::from_bits(rnd()),
                            ];
                            let v = bad[(rnd() % 4) as usize].to_le_bytes();
                            if i + 8 <= buf.len() {
                                buf[i..i + 8].copy_from_slice(&v);
                            }
                        }
                    }
                    let mut slot = std::ptr::null_mut();
                    let st = de_s(c, buf.as_ptr(), buf.len(), &mut slot);
                    if !slot.is_null() {
                        states.push((slot, None));
                    }
                    st
                }
                _ => enter(c),
            };
            const NAMES: [&str; 13] = [
                "setup",
                "enter",
                "exit",
                "terminate",
                "reset",
                "getReal",
                "setReal",
                "doStep",
                "doStep(random t)",
                "getFMUstate",
                "setFMUstate",
                "freeFMUstate",
                "deSerialize(corrupted)",
            ];
            if recent.len() == 12 {
                recent.pop_front();
            }
            recent.push_back(format!(
                "{}(vr {}, value {:e}) -> {st}",
                NAMES[op as usize], vr[0], v[0]
            ));
            // fmi2Warning only from getReal/doStep, for axis positions outside the box
            assert!(
                st == 0 || st == 3 || (st == 1 && matches!(op, 5 | 7 | 8)),
                "status {st} (MTWIN_FUZZ_SEED={seed0:#x}); last calls: {recent:#?}"
            );
            if op == 4 && st == 0 {
                t = 0.0;
            }
            if op == 5 && st <= 1 {
                assert!(
                    out[0].is_finite(),
                    "non-finite output {} (MTWIN_FUZZ_SEED={seed0:#x}); last calls: {recent:#?}",
                    out[0]
                );
            }
        }
        for (mut p, _) in states {
            assert_eq!(free_s(c, &mut p), 0);
        }
        free(c);
    }
}

/// The FMI 3.0 functions of the same library: instantiation refusals, NULL pointers, every
/// unsupported function, and a seeded random sequence of calls in any order — every call
/// returns OK, Warning or Error (Fatal would be a panic), outputs are finite, the
/// independent variable `time` follows the steps.
#[test]
fn fmi3_c_api_survives_misuse_and_random_call_sequences() {
    let (d, twin) = twin_dir();
    // FMI 3.0 passes a plain path with a trailing separator (no URI, no percent-encoding)
    let loc = format!("{}/res dir ü/", d.path().display());
    // SAFETY: loading our own library built by cargo; its initialisers are trivial.
    let lib = unsafe { Library::new(lib_path()) }.expect("load");
    type Inst = unsafe extern "C" fn(
        *const c_char,
        *const c_char,
        *const c_char,
        bool,
        bool,
        bool,
        bool,
        *const u32,
        usize,
        *mut c_void,
        *const c_void,
        *const c_void,
    ) -> Comp;
    type Free = unsafe extern "C" fn(Comp);
    type Simple = unsafe extern "C" fn(Comp) -> c_int;
    type Enter = unsafe extern "C" fn(Comp, bool, f64, f64, bool, f64) -> c_int;
    type GetF = unsafe extern "C" fn(Comp, *const u32, usize, *mut f64, usize) -> c_int;
    type SetF = unsafe extern "C" fn(Comp, *const u32, usize, *const f64, usize) -> c_int;
    type Step = unsafe extern "C" fn(
        Comp,
        f64,
        f64,
        bool,
        *mut bool,
        *mut bool,
        *mut bool,
        *mut f64,
    ) -> c_int;
    type GetS = unsafe extern "C" fn(Comp, *mut *mut c_void) -> c_int;
    type SetS = unsafe extern "C" fn(Comp, *mut c_void) -> c_int;
    type SizeS = unsafe extern "C" fn(Comp, *mut c_void, *mut usize) -> c_int;
    type SerS = unsafe extern "C" fn(Comp, *mut c_void, *mut u8, usize) -> c_int;
    type DeS = unsafe extern "C" fn(Comp, *const u8, usize, *mut *mut c_void) -> c_int;
    type GetI = unsafe extern "C" fn(Comp, *const u32, usize, *mut i32, usize) -> c_int;
    type DirD = unsafe extern "C" fn(
        Comp,
        *const u32,
        usize,
        *const u32,
        usize,
        *const f64,
        usize,
        *mut f64,
        usize,
    ) -> c_int;
    type Version = unsafe extern "C" fn() -> *const c_char;
    // SAFETY: the symbols have exactly these FMI 3.0 signatures (fmi3FunctionTypes.h).
    unsafe {
        let version: Symbol<Version> = lib.get(b"fmi3GetVersion").expect("sym");
        assert_eq!(std::ffi::CStr::from_ptr(version()).to_str(), Ok("3.0"));
        let inst: Symbol<Inst> = lib.get(b"fmi3InstantiateCoSimulation").expect("sym");
        let free: Symbol<Free> = lib.get(b"fmi3FreeInstance").expect("sym");
        let enter: Symbol<Enter> = lib.get(b"fmi3EnterInitializationMode").expect("sym");
        let exit: Symbol<Simple> = lib.get(b"fmi3ExitInitializationMode").expect("sym");
        let term: Symbol<Simple> = lib.get(b"fmi3Terminate").expect("sym");
        let reset: Symbol<Simple> = lib.get(b"fmi3Reset").expect("sym");
        let step_mode: Symbol<Simple> = lib.get(b"fmi3EnterStepMode").expect("sym");
        let event_mode: Symbol<Simple> = lib.get(b"fmi3EnterEventMode").expect("sym");
        let get: Symbol<GetF> = lib.get(b"fmi3GetFloat64").expect("sym");
        let set: Symbol<SetF> = lib.get(b"fmi3SetFloat64").expect("sym");
        let get_i: Symbol<GetI> = lib.get(b"fmi3GetInt32").expect("sym");
        let dir_d: Symbol<DirD> = lib.get(b"fmi3GetDirectionalDerivative").expect("sym");
        let step: Symbol<Step> = lib.get(b"fmi3DoStep").expect("sym");
        let get_s: Symbol<GetS> = lib.get(b"fmi3GetFMUState").expect("sym");
        let set_s: Symbol<SetS> = lib.get(b"fmi3SetFMUState").expect("sym");
        let free_s: Symbol<GetS> = lib.get(b"fmi3FreeFMUState").expect("sym");
        let size_s: Symbol<SizeS> = lib.get(b"fmi3SerializedFMUStateSize").expect("sym");
        let ser_s: Symbol<SerS> = lib.get(b"fmi3SerializeFMUState").expect("sym");
        let de_s: Symbol<DeS> = lib.get(b"fmi3DeserializeFMUState").expect("sym");
        let name = CString::new("t3").unwrap();
        let token = CString::new(twin.guid()).unwrap();
        let bad = CString::new("{bad}").unwrap();
        let cloc = CString::new(loc).unwrap();
        let null = std::ptr::null::<c_void>();
        let mk = |tok: &CString, loc: *const c_char, event_mode: bool| {
            inst(
                name.as_ptr(),
                tok.as_ptr(),
                loc,
                false,
                false,
                event_mode,
                false,
                std::ptr::null(),
                0,
                std::ptr::null_mut(),
                null,
                null,
            )
        };
        // wrong token, NULL resource path, event mode asked for: NULL instance
        assert!(mk(&bad, cloc.as_ptr(), false).is_null());
        assert!(mk(&token, std::ptr::null(), false).is_null());
        assert!(mk(&token, cloc.as_ptr(), true).is_null());
        let c = mk(&token, cloc.as_ptr(), false);
        assert!(!c.is_null(), "plain path with a space and ü");
        // the variables: Fx Fy, x y z, dx dy; time after them
        let time_vr = 7u32;
        // NULL instance, NULL arrays, lengths that do not match, unsupported functions
        assert_eq!(exit(std::ptr::null_mut()), 3);
        assert_eq!(get(c, std::ptr::null(), 2, std::ptr::null_mut(), 2), 3);
        assert_eq!(get(c, std::ptr::null(), 0, std::ptr::null_mut(), 0), 0);
        let mut two = [0.0f64; 2];
        assert_eq!(get(c, [5u32, 6].as_ptr(), 2, two.as_mut_ptr(), 1), 3);
        assert_eq!(get_i(c, [0u32].as_ptr(), 1, std::ptr::null_mut(), 1), 3);
        assert_eq!(get_i(c, std::ptr::null(), 0, std::ptr::null_mut(), 0), 0);
        assert_eq!(step_mode(c), 3);
        assert_eq!(event_mode(c), 3);
        let (nu, nf) = (std::ptr::null::<u32>(), std::ptr::null::<f64>());
        assert_eq!(dir_d(c, nu, 0, nu, 0, nf, 0, std::ptr::null_mut(), 0), 3);
        let nm = std::ptr::null_mut::<bool>();
        let (calls, mut seed) = fuzz_settings();
        let seed0 = seed;
        eprintln!("fmi3 fuzz: {calls} random calls, seed {seed0:#x}");
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let mut t = 0.0;
        let mut stepping = false;
        let mut states: Vec<*mut c_void> = Vec::new();
        let mut recent: std::collections::VecDeque<String> = Default::default();
        for _ in 0..calls {
            let r = rnd();
            let vr = [(r >> 8) as u32 % 10];
            let v = [f64::from_bits(rnd()) * if r & 1 == 0 { 1.0 } else { 0.0 }
                + ((r >> 20) % 1000) as f64];
            let mut out = [0.0f64];
            let op = r % 12;
            let pick = ((r >> 40) as usize) % states.len().max(1);
            let (mut ev, mut te, mut er, mut last) = (true, true, true, f64::NAN);
            let st = match op {
                0 => enter(c, false, 0.0, 0.0, false, 0.0),
                1 => exit(c),
                2 => term(c),
                3 => reset(c),
                4 => get(c, vr.as_ptr(), 1, out.as_mut_ptr(), 1),
                5 => set(c, vr.as_ptr(), 1, v.as_ptr(), 1),
                6 => {
                    let h = ((r >> 32) % 100) as f64 * 1e-5;
                    let s = step(c, t, h, true, &mut ev, &mut te, &mut er, &mut last);
                    assert!(!ev && !te && !er, "event/terminate/early flags set");
                    if s <= 1 {
                        t += h;
                        assert!((last - t).abs() <= 1e-12 * (1.0 + t), "{last} vs {t}");
                    }
                    s
                }
                7 => step(
                    c,
                    f64::from_bits(rnd()),
                    1e-3,
                    true,
                    nm,
                    nm,
                    nm,
                    std::ptr::null_mut(),
                ),
                8 => {
                    let mut slot = std::ptr::null_mut();
                    let s = get_s(c, &mut slot);
                    if !slot.is_null() {
                        states.push(slot);
                    }
                    s
                }
                9 if !states.is_empty() => {
                    // a restored state's time is not tracked here: read it back
                    let s = set_s(c, states[pick]);
                    let mut now = [0.0];
                    if get(c, [time_vr].as_ptr(), 1, now.as_mut_ptr(), 1) == 0 {
                        t = now[0];
                    }
                    s
                }
                10 if !states.is_empty() => {
                    let mut p = states.swap_remove(pick);
                    let s = free_s(c, &mut p);
                    assert!(p.is_null(), "freed state slot not cleared");
                    s
                }
                11 if !states.is_empty() => {
                    let mut n = 0usize;
                    assert_eq!(size_s(c, states[pick], &mut n), 0);
                    let mut buf = vec![0u8; n];
                    assert_eq!(ser_s(c, states[pick], buf.as_mut_ptr(), n), 0);
                    if r & 4 == 0 && n > 0 {
                        let i = (rnd() as usize) % n;
                        buf[i] ^= 1 << (rnd() % 8);
                    }
                    let mut slot = std::ptr::null_mut();
                    let s = de_s(c, buf.as_ptr(), buf.len(), &mut slot);
                    if !slot.is_null() {
                        states.push(slot);
                    }
                    s
                }
                _ => get(c, [time_vr].as_ptr(), 1, out.as_mut_ptr(), 1),
            };
            if recent.len() == 12 {
                recent.pop_front();
            }
            recent.push_back(format!("op {op} (vr {}, value {:e}) -> {st}", vr[0], v[0]));
            assert!(
                st == 0 || st == 3 || (st == 1 && matches!(op, 4 | 6 | 7)),
                "status {st} (MTWIN_FUZZ_SEED={seed0:#x}); last calls: {recent:#?}"
            );
            match (op, st) {
                (1, 0) => stepping = true,
                (3, 0) => {
                    t = 0.0;
                    stepping = false;
                }
                (4, 0 | 1) => assert!(
                    out[0].is_finite(),
                    "non-finite output {} (MTWIN_FUZZ_SEED={seed0:#x}); last calls: {recent:#?}",
                    out[0]
                ),
                _ => {}
            }
            // the independent variable is the slave's time
            let mut now = [f64::NAN];
            if stepping && get(c, [time_vr].as_ptr(), 1, now.as_mut_ptr(), 1) == 0 {
                assert!(now[0].is_finite(), "time {}", now[0]);
            }
        }
        for mut p in states {
            assert_eq!(free_s(c, &mut p), 0);
        }
        free(c);
    }
}
