//! The calls of the driver: instantiation and the life cycle, getters and setters of every
//! kind, Co-Simulation steps and the functions this FMU does not offer.

use super::*;

/// The categories `fmi3SetDebugLogging` is given (the last: not UTF-8).
const CATEGORIES: [&CStr; 5] = [
    c"logStatusError",
    c"logStatusWarning",
    c"logEvents",
    c"logAll",
    c"bogus",
];
const NOT_UTF8: &[u8] = b"log\xff\xfe\0";

impl<M: Model> Driver<M> {
    /// `bad % 6`: 0 valid arguments, 1 NULL instanceName, 2 empty instanceName, 3 another
    /// token, 4 NULL token, 5 a token that is not UTF-8.
    pub(super) unsafe fn instantiate(&mut self, k: usize, l: &Lifecycle) {
        let Lifecycle::Instantiate {
            me,
            bad,
            logger: with_logger,
            event_mode,
            required,
        } = *l
        else {
            return;
        };
        self.insts[k].free();
        let guid = std::ffi::CString::new(fmi3_export::fmu_core::xml::guid::<M>()).unwrap();
        let (name, token) = match bad % 6 {
            0 => (c"fuzz".as_ptr(), guid.as_ptr()),
            1 => (std::ptr::null(), guid.as_ptr()),
            2 => (c"".as_ptr(), guid.as_ptr()),
            3 => (c"fuzz".as_ptr(), c"{nope}".as_ptr()),
            4 => (c"fuzz".as_ptr(), std::ptr::null()),
            _ => (c"fuzz".as_ptr(), NOT_UTF8.as_ptr() as *const c_char),
        };
        let env = &ENVIRONMENTS[k] as *const u8 as *mut c_void;
        let log: Fmi3LogMessageCallback = if with_logger { Some(logger) } else { None };
        let required_vrs: Vec<u32> = (0..required as u32 % 3).collect();
        let c = if me {
            f::fmi3InstantiateModelExchange(name, token, std::ptr::null(), false, true, env, log)
        } else {
            let n_req = required_vrs.len();
            f::fmi3InstantiateCoSimulation(
                name,
                token,
                std::ptr::null(),
                false,
                true,
                event_mode,
                false,
                required_vrs.as_ptr(),
                n_req,
                env,
                log,
                None,
            )
        };
        let refused = bad % 6 != 0 || (!me && (event_mode || !required_vrs.is_empty()));
        let log_lines = take_log();
        if refused {
            assert!(c.is_null(), "bad instantiation {l:?} accepted");
            assert!(
                !with_logger || !log_lines.is_empty(),
                "refused {l:?} logged nothing"
            );
        } else {
            assert!(
                !c.is_null(),
                "valid instantiation {l:?} refused: {log_lines:?}"
            );
        }
        self.insts[k] = Inst {
            c,
            states: Vec::new(),
            time: 0.0,
            logs: with_logger,
        };
    }

    pub(super) unsafe fn lifecycle(&mut self, k: usize, l: &Lifecycle) {
        let c = self.insts[k].c;
        let s = match l {
            Lifecycle::Instantiate { .. } => return self.instantiate(k, l),
            Lifecycle::ScheduledExecution => {
                let env = &ENVIRONMENTS[k] as *const u8 as *mut c_void;
                let se = f::fmi3InstantiateScheduledExecution(
                    c"fuzz".as_ptr(),
                    c"t".as_ptr(),
                    std::ptr::null(),
                    false,
                    false,
                    env,
                    Some(logger),
                    None,
                    None,
                    None,
                );
                assert!(se.is_null(), "Scheduled Execution instantiated");
                assert!(
                    !take_log().is_empty(),
                    "refused Scheduled Execution logged nothing"
                );
                return;
            }
            Lifecycle::Free => return self.insts[k].free(),
            Lifecycle::SetDebugLogging { on, cats, null } => {
                let list: Vec<Fmi3String> = cats
                    .iter()
                    .map(|&i| match i as usize % 7 {
                        5 => std::ptr::null(),
                        6 => NOT_UTF8.as_ptr() as *const c_char,
                        j => CATEGORIES[j].as_ptr(),
                    })
                    .collect();
                f::fmi3SetDebugLogging(c, *on, list.len(), ptr(&list, *null))
            }
            Lifecycle::EnterInit {
                tolerance,
                start,
                stop,
            } => {
                let (tol, t0, tend) = (tolerance.map(F::get), start.get(), stop.map(F::get));
                let s = f::fmi3EnterInitializationMode(
                    c,
                    tol.is_some(),
                    tol.unwrap_or(0.0),
                    t0,
                    tend.is_some(),
                    tend.unwrap_or(0.0),
                );
                if s == FMI3_OK {
                    self.insts[k].time = t0;
                }
                s
            }
            Lifecycle::ExitInit => f::fmi3ExitInitializationMode(c),
            Lifecycle::Terminate => f::fmi3Terminate(c),
            Lifecycle::Reset => {
                let s = f::fmi3Reset(c);
                if s == FMI3_OK {
                    self.insts[k].time = 0.0;
                }
                s
            }
        };
        self.insts[k].check(s, l);
    }

    /// One getter or setter. Must fail: a NULL array with a non-zero count, `nValues !=
    /// nValueReferences` (all variables are scalars, even with no reference), a reference that is not a variable of the type (setters: `time` and
    /// the event indicators neither), any clock.
    pub(super) unsafe fn access(&mut self, k: usize, a: &Access) {
        let c = self.insts[k].c;
        let mut vrs = Self::vrs(&a.vrs);
        if a.null_vrs {
            vrs.truncate(1);
        }
        let nvr = vrs.len();
        let vr_ptr = ptr(&vrs, a.null_vrs);
        let ty = match a.ty {
            Ty::Float64 => Some(VarType::Real),
            Ty::Int32 => Some(VarType::Integer),
            Ty::Boolean => Some(VarType::Boolean),
            _ => None,
        };
        let vals: Vec<f64> = vrs
            .iter()
            .zip(a.vals.iter().chain(std::iter::repeat(&Val::Start)))
            .map(|(&vr, &v)| Self::value(vr, v))
            .collect();
        let (vals, null_vals) = counted(&vals, a.count, 0.0);
        let nv = vals.len();
        let settable = |vr: u32| {
            ty.is_some_and(|t| Self::is_of(vr, t))
                && (a.get || (vr != TIME_VALUE_REFERENCE && vr < EVENT_INDICATOR_VALUE_REFERENCE))
        };
        let must_fail = (a.null_vrs && nvr > 0)
            || (null_vals && nv > 0 && a.ty != Ty::Clock)
            || (a.ty != Ty::Clock && nv != nvr)
            || !vrs.iter().all(|&vr| settable(vr))
            || a.ty == Ty::Clock;
        let s = match a.ty {
            Ty::Float64 | Ty::Int32 | Ty::Boolean => {
                self.typed(c, a, (vr_ptr, nvr), (&vals, null_vals))
            }
            Ty::String => self.strings(c, a.get, (vr_ptr, nvr), (nv, null_vals)),
            Ty::Binary => self.binaries(c, a, (vr_ptr, nvr), (nv, null_vals)),
            Ty::Clock => {
                let mut ticks = vec![false; nvr];
                let p = ptr_mut(&mut ticks, null_vals);
                if a.get {
                    f::fmi3GetClock(c, vr_ptr, nvr, p)
                } else {
                    f::fmi3SetClock(c, vr_ptr, nvr, p)
                }
            }
            Ty::Float32 => {
                let mut v = vec![0f32; nv];
                let p = ptr_mut(&mut v, null_vals);
                if a.get {
                    f::fmi3GetFloat32(c, vr_ptr, nvr, p, nv)
                } else {
                    f::fmi3SetFloat32(c, vr_ptr, nvr, p, nv)
                }
            }
            Ty::UInt64 => {
                let mut v = vec![7u64; nv];
                let p = ptr_mut(&mut v, null_vals);
                if a.get {
                    f::fmi3GetUInt64(c, vr_ptr, nvr, p, nv)
                } else {
                    f::fmi3SetUInt64(c, vr_ptr, nvr, p, nv)
                }
            }
        };
        if must_fail {
            assert_eq!(
                s,
                FMI3_ERROR,
                "{a:?} (value references {vrs:?}) did not fail: {:?}",
                take_log()
            );
        }
        self.insts[k].check(s, a);
    }

    /// Float64, Int32, Boolean; an fmi3OK getter gives finite numbers and Booleans 0 or 1.
    unsafe fn typed(
        &self,
        c: Fmi3Instance,
        a: &Access,
        (vr_ptr, nvr): (*const u32, usize),
        (vals, null): (&[f64], bool),
    ) -> Fmi3Status {
        let nv = vals.len();
        match (a.ty, a.get) {
            (Ty::Float64, true) => {
                let mut out = vec![0.0; nv];
                let s = f::fmi3GetFloat64(c, vr_ptr, nvr, ptr_mut(&mut out, null), nv);
                if s == FMI3_OK {
                    assert!(
                        out.iter().all(|x| x.is_finite()),
                        "fmi3GetFloat64 gave {out:?}"
                    );
                }
                s
            }
            (Ty::Float64, false) => f::fmi3SetFloat64(c, vr_ptr, nvr, ptr(vals, null), nv),
            (Ty::Int32, true) => {
                let mut out = vec![0i32; nv];
                f::fmi3GetInt32(c, vr_ptr, nvr, ptr_mut(&mut out, null), nv)
            }
            (Ty::Int32, false) => {
                let ints: Vec<i32> = vals.iter().map(|&x| x as i32).collect();
                f::fmi3SetInt32(c, vr_ptr, nvr, ptr(&ints, null), nv)
            }
            (_, true) => {
                // written by the FMU as C bool; read back as bytes
                let mut out = vec![0u8; nv];
                let p = ptr_mut(&mut out, null) as *mut Fmi3Boolean;
                let s = f::fmi3GetBoolean(c, vr_ptr, nvr, p, nv);
                if s == FMI3_OK {
                    assert!(out.iter().all(|&b| b <= 1), "fmi3GetBoolean gave {out:?}");
                }
                s
            }
            (_, false) => {
                // any byte: the FMU must read the importer's Booleans as bytes, not as Rust bool
                let mut bytes: Vec<u8> = a
                    .bytes
                    .iter()
                    .copied()
                    .chain(std::iter::repeat(1))
                    .take(nv)
                    .collect();
                let p = ptr_mut(&mut bytes, null) as *const Fmi3Boolean;
                f::fmi3SetBoolean(c, vr_ptr, nvr, p, nv)
            }
        }
    }

    unsafe fn strings(
        &self,
        c: Fmi3Instance,
        get: bool,
        (vr_ptr, nvr): (*const u32, usize),
        (nv, null): (usize, bool),
    ) -> Fmi3Status {
        let mut v: Vec<Fmi3String> = (0..nv)
            .map(|i| {
                if i % 2 == 0 {
                    c"text".as_ptr()
                } else {
                    std::ptr::null()
                }
            })
            .collect();
        if get {
            f::fmi3GetString(c, vr_ptr, nvr, ptr_mut(&mut v, null), nv)
        } else {
            f::fmi3SetString(c, vr_ptr, nvr, ptr(&v, null), nv)
        }
    }

    unsafe fn binaries(
        &self,
        c: Fmi3Instance,
        a: &Access,
        (vr_ptr, nvr): (*const u32, usize),
        (nv, null): (usize, bool),
    ) -> Fmi3Status {
        let mut sizes: Vec<usize> = (0..nv).map(|i| a.bytes.len().min(i)).collect();
        let mut values: Vec<Fmi3Binary> = (0..nv).map(|_| a.bytes.as_ptr()).collect();
        if a.get {
            let (sp, vp) = (ptr_mut(&mut sizes, null), ptr_mut(&mut values, null));
            f::fmi3GetBinary(c, vr_ptr, nvr, sp, vp, nv)
        } else {
            f::fmi3SetBinary(c, vr_ptr, nvr, ptr(&sizes, null), ptr(&values, null), nv)
        }
    }

    /// `fmi3DoStep`: NULL outputs fail; an fmi3OK step reports `lastSuccessfulTime = t + h`
    /// and leaves every Float64 finite, `time` at t + h.
    pub(super) unsafe fn step(&mut self, k: usize, step: &Step) {
        let inst = &self.insts[k];
        let (t, h) = match step.kind {
            StepKind::Normal(n) => (inst.time, (n as f64 + 1.0) * 0.05 / 256.0),
            StepKind::WrongTime(d, n) => (inst.time + d.get(), (n as f64 + 1.0) * 1e-3),
            StepKind::Bad(x) => (inst.time, x.get().min(1.0)),
        };
        let (mut event, mut stop, mut early, mut last) = (true, true, true, f64::NAN);
        let bit = |i: u8| step.null_outputs & (1 << i) != 0;
        let s = f::fmi3DoStep(
            inst.c,
            t,
            h,
            false,
            if bit(0) {
                std::ptr::null_mut()
            } else {
                &mut event
            },
            if bit(1) {
                std::ptr::null_mut()
            } else {
                &mut stop
            },
            if bit(2) {
                std::ptr::null_mut()
            } else {
                &mut early
            },
            if bit(3) {
                std::ptr::null_mut()
            } else {
                &mut last
            },
        );
        if step.null_outputs & 0xf != 0 {
            assert_eq!(s, FMI3_ERROR, "fmi3DoStep with a NULL output did not fail");
        }
        inst.check(s, step);
        if s != FMI3_OK {
            return;
        }
        assert_eq!(
            last,
            t + h,
            "lastSuccessfulTime after an fmi3OK step from {t} by {h}"
        );
        assert!(
            !event && !stop && !early,
            "fmi3DoStep outputs {event} {stop} {early}"
        );
        let c = inst.c;
        self.insts[k].time = t + h;
        let vrs = float64_vrs::<M>();
        let mut out = vec![0.0; vrs.len()];
        let s2 = f::fmi3GetFloat64(c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr(), out.len());
        assert_eq!(
            s2,
            FMI3_OK,
            "fmi3GetFloat64 after a good step failed: {:?}",
            take_log()
        );
        assert!(
            out.iter().all(|x| x.is_finite()),
            "non-finite value after an fmi3OK step"
        );
        assert_eq!(out.last(), Some(&(t + h)), "time after the step");
    }

    /// The functions this FMU does not offer: fmi3Error with a logged reason, in any state.
    pub(super) unsafe fn unsupported(&mut self, k: usize, which: u8) {
        let c = self.insts[k].c;
        let vr = [0u32];
        let (mut x, mut n, mut q) = ([0.0f64; 1], [0u64; 1], [0i32; 1]);
        let (mut dep_n, order) = (0usize, [1i32]);
        let s = match which % 16 {
            0 => f::fmi3EnterConfigurationMode(c),
            1 => f::fmi3ExitConfigurationMode(c),
            2 => f::fmi3EnterStepMode(c),
            3 => f::fmi3GetOutputDerivatives(c, vr.as_ptr(), 1, order.as_ptr(), x.as_mut_ptr(), 1),
            4 => f::fmi3GetIntervalDecimal(c, vr.as_ptr(), 1, x.as_mut_ptr(), q.as_mut_ptr()),
            5 => f::fmi3GetIntervalFraction(
                c,
                vr.as_ptr(),
                1,
                n.as_mut_ptr(),
                n.as_mut_ptr(),
                q.as_mut_ptr(),
            ),
            6 => f::fmi3GetShiftDecimal(c, vr.as_ptr(), 1, x.as_mut_ptr()),
            7 => f::fmi3GetShiftFraction(c, vr.as_ptr(), 1, n.as_mut_ptr(), n.as_mut_ptr()),
            8 => f::fmi3SetIntervalDecimal(c, vr.as_ptr(), 1, x.as_ptr()),
            9 => f::fmi3SetIntervalFraction(c, vr.as_ptr(), 1, n.as_ptr(), n.as_ptr()),
            10 => f::fmi3SetShiftDecimal(c, vr.as_ptr(), 1, x.as_ptr()),
            11 => f::fmi3SetShiftFraction(c, vr.as_ptr(), 1, n.as_ptr(), n.as_ptr()),
            12 => f::fmi3EvaluateDiscreteStates(c),
            13 => f::fmi3ActivateModelPartition(c, 0, 0.0),
            14 => f::fmi3GetNumberOfVariableDependencies(c, 0, &mut dep_n),
            _ => {
                let (mut ei, mut ind, mut eii, mut kinds) = ([0usize], [0u32], [0usize], [0i32]);
                f::fmi3GetVariableDependencies(
                    c,
                    0,
                    ei.as_mut_ptr(),
                    ind.as_mut_ptr(),
                    eii.as_mut_ptr(),
                    kinds.as_mut_ptr(),
                    1,
                )
            }
        };
        assert_eq!(
            s,
            FMI3_ERROR,
            "unsupported function {} did not fail",
            which % 16
        );
        self.insts[k].check(s, &which);
        let _ = f::fmi3GetVersion();
    }
}
