//! The built shared library through its C API, loaded with libloading (as an importer
//! would): life cycle, NULL pointers, unknown references, and a seeded random sequence of
//! calls in any order — every call returns a status, none crashes the host.
//!
//! `MTWIN_FUZZ_CALLS` (default 20000) sets the number of random calls and
//! `MTWIN_FUZZ_SEED` (default a fixed seed) the seed; `scripts/fuzz.sh` raises both.

use identify::axis::Axis;
use identify::twin::Twin;
use libloading::{Library, Symbol};
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
        for _ in 0..calls {
            let r = rnd();
            let vr = [(r >> 8) as u32 % 10];
            let v = [f64::from_bits(rnd()) * if r & 1 == 0 { 1.0 } else { 0.0 }
                + ((r >> 20) % 1000) as f64];
            let mut out = [0.0f64];
            let st = match r % 9 {
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
                    if s == 0 {
                        t += h;
                    }
                    s
                }
                _ => step(c, f64::from_bits(rnd()), 1e-3, 1),
            };
            assert!(
                st == 0 || st == 3,
                "status {st} (MTWIN_FUZZ_SEED={seed0:#x})"
            );
            if r % 9 == 4 && st == 0 {
                t = 0.0;
            }
            if r % 9 == 5 && st == 0 {
                assert!(
                    out[0].is_finite(),
                    "non-finite output (MTWIN_FUZZ_SEED={seed0:#x})"
                );
            }
        }
        free(c);
    }
}
