//! The Model Exchange calls of the driver (they fail on a Co-Simulation instance) and the
//! directional and adjoint derivatives of both interfaces.

use super::*;

/// The model's number of continuous states and of event indicators.
fn sizes<M: Model>() -> (usize, usize) {
    M::model_exchange().map_or((0, 0), |me| (me.states, me.event_indicators))
}

impl<M: Model> Driver<M> {
    pub(super) unsafe fn model_exchange(&mut self, k: usize, op: &MeOp) {
        let c = self.insts[k].c;
        let (nx, nz) = sizes::<M>();
        let s = match op {
            MeOp::SetTime(t) => f::fmi3SetTime(c, t.get()),
            MeOp::SetContinuousStates { x, count } => {
                let values: Vec<f64> = (0..nx).map(|i| x.get(i).map_or(0.5, |v| v.get())).collect();
                let (values, null) = counted(&values, *count, 0.0);
                let s = f::fmi3SetContinuousStates(c, ptr(&values, null), values.len());
                if values.len() != nx || (null && !values.is_empty()) {
                    assert_eq!(
                        s,
                        FMI3_ERROR,
                        "{op:?} with {} of {nx} states accepted",
                        values.len()
                    );
                }
                s
            }
            MeOp::GetArray { which, count } => self.get_array(c, *which, *count, (nx, nz)),
            MeOp::CompletedIntegratorStep {
                no_set_prior,
                null_outputs,
            } => {
                let (mut enter, mut stop) = (false, false);
                let p0 = if null_outputs & 1 != 0 {
                    std::ptr::null_mut()
                } else {
                    &mut enter as *mut _
                };
                let p1 = if null_outputs & 2 != 0 {
                    std::ptr::null_mut()
                } else {
                    &mut stop as *mut _
                };
                let s = f::fmi3CompletedIntegratorStep(c, *no_set_prior, p0, p1);
                if null_outputs & 3 != 0 {
                    assert_eq!(s, FMI3_ERROR, "{op:?} with a NULL output accepted");
                }
                s
            }
            MeOp::UpdateDiscreteStates { null_outputs } => {
                self.update_discrete_states(c, *null_outputs)
            }
            MeOp::EnterEventMode => f::fmi3EnterEventMode(c),
            MeOp::EnterContinuousTimeMode => f::fmi3EnterContinuousTimeMode(c),
            MeOp::NumberOf { indicators, null } => {
                let mut n = usize::MAX;
                let p = if *null {
                    std::ptr::null_mut()
                } else {
                    &mut n as *mut usize
                };
                let s = if *indicators {
                    f::fmi3GetNumberOfEventIndicators(c, p)
                } else {
                    f::fmi3GetNumberOfContinuousStates(c, p)
                };
                if s == FMI3_OK {
                    assert_eq!(n, if *indicators { nz } else { nx }, "{op:?}");
                }
                if *null {
                    assert_eq!(s, FMI3_ERROR, "{op:?} with a NULL output accepted");
                }
                s
            }
            MeOp::Derivative { .. } => self.derivative(c, op),
        };
        self.insts[k].check(s, op);
    }

    /// 0 derivatives (nx), 1 event indicators (nz), 2 states (nx), 3 nominals (nx, each > 0).
    unsafe fn get_array(
        &self,
        c: Fmi3Instance,
        which: u8,
        count: Count,
        (nx, nz): (usize, usize),
    ) -> Fmi3Status {
        let n = if which % 4 == 1 { nz } else { nx };
        let (mut out, null) = counted(&vec![f64::NAN; n], count, f64::NAN);
        let (p, len) = (ptr_mut(&mut out, null), out.len());
        let s = match which % 4 {
            0 => f::fmi3GetContinuousStateDerivatives(c, p, len),
            1 => f::fmi3GetEventIndicators(c, p, len),
            2 => f::fmi3GetContinuousStates(c, p, len),
            _ => f::fmi3GetNominalsOfContinuousStates(c, p, len),
        };
        if len != n || (null && len > 0) {
            assert_eq!(
                s,
                FMI3_ERROR,
                "array getter {} with {len} of {n} elements accepted",
                which % 4
            );
        }
        if s == FMI3_OK && which % 4 == 3 {
            assert!(
                out.iter().all(|x| x.is_finite() && *x > 0.0),
                "nominals {out:?}"
            );
        }
        s
    }

    unsafe fn update_discrete_states(&self, c: Fmi3Instance, null_outputs: u8) -> Fmi3Status {
        let mut b = [false; 5];
        let mut next = f64::NAN;
        let [b0, b1, b2, b3, b4] = &mut b;
        let out = |i: u8, p: &mut bool| -> *mut bool {
            if null_outputs & (1 << i) != 0 {
                std::ptr::null_mut()
            } else {
                p
            }
        };
        let next_p = if null_outputs & 32 != 0 {
            std::ptr::null_mut()
        } else {
            &mut next as *mut f64
        };
        let s = f::fmi3UpdateDiscreteStates(
            c,
            out(0, b0),
            out(1, b1),
            out(2, b2),
            out(3, b3),
            out(4, b4),
            next_p,
        );
        if null_outputs & 63 != 0 {
            assert_eq!(
                s, FMI3_ERROR,
                "fmi3UpdateDiscreteStates with a NULL output accepted"
            );
        }
        if s == FMI3_OK && b[4] {
            assert!(next.is_finite(), "nextEventTime {next} defined");
        }
        s
    }

    /// `fmi3GetDirectionalDerivative` / `fmi3GetAdjointDerivative`: seed and sensitivity sized
    /// by the knowns and unknowns (swapped for the adjoint), or not.
    unsafe fn derivative(&self, c: Fmi3Instance, op: &MeOp) -> Fmi3Status {
        let MeOp::Derivative {
            adjoint,
            unknowns,
            knowns,
            seed,
            seed_count,
            sensitivity_count,
        } = op
        else {
            return FMI3_ERROR;
        };
        let (u, kn) = (Self::vrs(unknowns), Self::vrs(knowns));
        let (n_seed, n_sens) = if *adjoint {
            (u.len(), kn.len())
        } else {
            (kn.len(), u.len())
        };
        let seed: Vec<f64> = (0..n_seed)
            .map(|i| seed.get(i).map_or(1.0, |x| x.get()))
            .collect();
        let (seed, null_seed) = counted(&seed, *seed_count, 1.0);
        let (mut sens, null_sens) = counted(&vec![0.0; n_sens], *sensitivity_count, 0.0);
        let (ns, nsens) = (seed.len(), sens.len());
        let args = (
            u.as_ptr(),
            u.len(),
            kn.as_ptr(),
            kn.len(),
            ptr(&seed, null_seed),
            ns,
        );
        let s = if *adjoint {
            f::fmi3GetAdjointDerivative(
                c,
                args.0,
                args.1,
                args.2,
                args.3,
                args.4,
                args.5,
                ptr_mut(&mut sens, null_sens),
                nsens,
            )
        } else {
            f::fmi3GetDirectionalDerivative(
                c,
                args.0,
                args.1,
                args.2,
                args.3,
                args.4,
                args.5,
                ptr_mut(&mut sens, null_sens),
                nsens,
            )
        };
        let wrong =
            ns != n_seed || nsens != n_sens || (null_seed && ns > 0) || (null_sens && nsens > 0);
        if wrong {
            assert_eq!(
                s, FMI3_ERROR,
                "{op:?} with nSeed {ns}, nSensitivity {nsens} accepted"
            );
        }
        s
    }
}
