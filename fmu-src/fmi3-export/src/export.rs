//! [`export_fmi3!`]: the `#[no_mangle] extern "C"` symbols of all 75 FMI 3.0 functions, each a
//! call to the generic function of the same name in [`crate::ffi`], [`crate::me`] or
//! [`crate::states`].

/// Export all 75 FMI 3.0 functions for model type `$model` from this `cdylib`. Co-Simulation and
/// (for a model with `ModelExchange`) Model Exchange, with directional and adjoint derivatives in
/// both (for a model with an analytic Jacobian), are implemented; Scheduled Execution, Event
/// Mode in Co-Simulation, clocks, configuration mode, intermediate update and per-element
/// dependencies return `fmi3Error` with a logged reason.
#[macro_export]
macro_rules! export_fmi3 {
    ($model:ty) => {
        /// The exported model type, named where the macro is invoked (so a bare name resolves).
        type Fmi3ExportedModel = $model;

        mod fmi3_exports {
            #![allow(non_snake_case, unused_imports, clippy::missing_safety_doc, clippy::too_many_arguments)]
            use $crate::fmi_types::c3::*;
            use $crate::ffi::*;
            use $crate::me::*;
            use $crate::states::*;
            use std::ffi::c_void;
            use super::Fmi3ExportedModel as M;

            const NO_CLOCKS: &str = "this FMU has no clocks";

            // ---- common functions
            #[no_mangle]
            pub extern "C" fn fmi3GetVersion() -> Fmi3String {
                get_version()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetDebugLogging(
                c: Fmi3Instance, on: Fmi3Boolean, n: usize, cats: *const Fmi3String,
            ) -> Fmi3Status {
                set_debug_logging::<M>(c, on, n, cats)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3InstantiateModelExchange(
                name: Fmi3String, token: Fmi3String, _resources: Fmi3String,
                _visible: Fmi3Boolean, logging: Fmi3Boolean,
                env: Fmi3InstanceEnvironment, log: Fmi3LogMessageCallback,
            ) -> Fmi3Instance {
                instantiate_model_exchange::<M>((name, token), logging, (env, log))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
                name: Fmi3String, token: Fmi3String, _resources: Fmi3String,
                _visible: Fmi3Boolean, logging: Fmi3Boolean, event_mode_used: Fmi3Boolean,
                _early_return_allowed: Fmi3Boolean, _required: *const Fmi3ValueReference,
                n_required: usize, env: Fmi3InstanceEnvironment, log: Fmi3LogMessageCallback,
                _intermediate_update: Fmi3IntermediateUpdateCallback,
            ) -> Fmi3Instance {
                instantiate_co_simulation::<M>((name, token), event_mode_used, n_required, logging, (env, log))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3InstantiateScheduledExecution(
                _name: Fmi3String, _token: Fmi3String, _resources: Fmi3String,
                _visible: Fmi3Boolean, _logging: Fmi3Boolean,
                env: Fmi3InstanceEnvironment, log: Fmi3LogMessageCallback,
                _clock_update: Fmi3ClockUpdateCallback, _lock: Fmi3PreemptionCallback,
                _unlock: Fmi3PreemptionCallback,
            ) -> Fmi3Instance {
                instantiate_refused::<M>("fmi3InstantiateScheduledExecution", "Scheduled Execution", env, log)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3FreeInstance(c: Fmi3Instance) {
                free_instance::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterInitializationMode(
                c: Fmi3Instance, tol_defined: Fmi3Boolean, tol: Fmi3Float64, start: Fmi3Float64,
                stop_defined: Fmi3Boolean, stop: Fmi3Float64,
            ) -> Fmi3Status {
                enter_initialization_mode::<M>(c, (tol_defined, tol), start, (stop_defined, stop))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3ExitInitializationMode(c: Fmi3Instance) -> Fmi3Status {
                exit_initialization_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterEventMode(c: Fmi3Instance) -> Fmi3Status {
                enter_event_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3Terminate(c: Fmi3Instance) -> Fmi3Status {
                terminate::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3Reset(c: Fmi3Instance) -> Fmi3Status {
                reset::<M>(c)
            }

            // ---- getters and setters: Float64, Int32 and Boolean variables exist
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetFloat64(
                c: Fmi3Instance, vr: *const Fmi3ValueReference, nvr: usize,
                v: *mut Fmi3Float64, nv: usize,
            ) -> Fmi3Status {
                get_float64::<M>(c, vr, nvr, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetInt32(
                c: Fmi3Instance, vr: *const Fmi3ValueReference, nvr: usize,
                v: *mut Fmi3Int32, nv: usize,
            ) -> Fmi3Status {
                get_int32::<M>(c, vr, nvr, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetBoolean(
                c: Fmi3Instance, vr: *const Fmi3ValueReference, nvr: usize,
                v: *mut Fmi3Boolean, nv: usize,
            ) -> Fmi3Status {
                get_boolean::<M>(c, vr, nvr, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetFloat64(
                c: Fmi3Instance, vr: *const Fmi3ValueReference, nvr: usize,
                v: *const Fmi3Float64, nv: usize,
            ) -> Fmi3Status {
                set_float64::<M>(c, vr, nvr, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetInt32(
                c: Fmi3Instance, vr: *const Fmi3ValueReference, nvr: usize,
                v: *const Fmi3Int32, nv: usize,
            ) -> Fmi3Status {
                set_int32::<M>(c, vr, nvr, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetBoolean(
                c: Fmi3Instance, vr: *const Fmi3ValueReference, nvr: usize,
                v: *const Fmi3Boolean, nv: usize,
            ) -> Fmi3Status {
                set_boolean::<M>(c, vr, nvr, v, nv)
            }

            // ---- types without variables: an empty list succeeds, any reference is refused
            $crate::__fmi3_no_type!(fmi3GetFloat32, "Float32", *mut Fmi3Float32, getter);
            $crate::__fmi3_no_type!(fmi3GetInt8, "Int8", *mut Fmi3Int8, getter);
            $crate::__fmi3_no_type!(fmi3GetUInt8, "UInt8", *mut Fmi3UInt8, getter);
            $crate::__fmi3_no_type!(fmi3GetInt16, "Int16", *mut Fmi3Int16, getter);
            $crate::__fmi3_no_type!(fmi3GetUInt16, "UInt16", *mut Fmi3UInt16, getter);
            $crate::__fmi3_no_type!(fmi3GetUInt32, "UInt32", *mut Fmi3UInt32, getter);
            $crate::__fmi3_no_type!(fmi3GetInt64, "Int64", *mut Fmi3Int64, getter);
            $crate::__fmi3_no_type!(fmi3GetUInt64, "UInt64", *mut Fmi3UInt64, getter);
            $crate::__fmi3_no_type!(fmi3GetString, "String", *mut Fmi3String, getter);
            $crate::__fmi3_no_type!(fmi3SetFloat32, "Float32", *const Fmi3Float32, setter);
            $crate::__fmi3_no_type!(fmi3SetInt8, "Int8", *const Fmi3Int8, setter);
            $crate::__fmi3_no_type!(fmi3SetUInt8, "UInt8", *const Fmi3UInt8, setter);
            $crate::__fmi3_no_type!(fmi3SetInt16, "Int16", *const Fmi3Int16, setter);
            $crate::__fmi3_no_type!(fmi3SetUInt16, "UInt16", *const Fmi3UInt16, setter);
            $crate::__fmi3_no_type!(fmi3SetUInt32, "UInt32", *const Fmi3UInt32, setter);
            $crate::__fmi3_no_type!(fmi3SetInt64, "Int64", *const Fmi3Int64, setter);
            $crate::__fmi3_no_type!(fmi3SetUInt64, "UInt64", *const Fmi3UInt64, setter);
            $crate::__fmi3_no_type!(fmi3SetString, "String", *const Fmi3String, setter);
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetBinary(
                c: Fmi3Instance, vr: *const Fmi3ValueReference, nvr: usize,
                _sizes: *mut usize, _v: *mut Fmi3Binary, nv: usize,
            ) -> Fmi3Status {
                no_variables_of_type::<M>(c, $crate::calls::getter("fmi3GetBinary"), "Binary", (vr, nvr), nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetBinary(
                c: Fmi3Instance, vr: *const Fmi3ValueReference, nvr: usize,
                _sizes: *const usize, _v: *const Fmi3Binary, nv: usize,
            ) -> Fmi3Status {
                no_variables_of_type::<M>(c, $crate::calls::setter("fmi3SetBinary"), "Binary", (vr, nvr), nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetClock(
                c: Fmi3Instance, _vr: *const Fmi3ValueReference, _nvr: usize, _v: *mut Fmi3Clock,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3GetClock", NO_CLOCKS)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetClock(
                c: Fmi3Instance, _vr: *const Fmi3ValueReference, _nvr: usize, _v: *const Fmi3Clock,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3SetClock", NO_CLOCKS)
            }

            // ---- variable dependencies
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetNumberOfVariableDependencies(
                c: Fmi3Instance, _vr: Fmi3ValueReference, _n: *mut usize,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3GetNumberOfVariableDependencies",
                    "dependencies are given in modelDescription.xml only (providesPerElementDependencies=\"false\")")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetVariableDependencies(
                c: Fmi3Instance, _dependent: Fmi3ValueReference, _ei: *mut usize,
                _independents: *mut Fmi3ValueReference, _eii: *mut usize,
                _kinds: *mut Fmi3DependencyKind, _n: usize,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3GetVariableDependencies",
                    "dependencies are given in modelDescription.xml only (providesPerElementDependencies=\"false\")")
            }

            // ---- FMU state
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetFMUState(c: Fmi3Instance, s: *mut Fmi3FmuState) -> Fmi3Status {
                get_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetFMUState(c: Fmi3Instance, s: Fmi3FmuState) -> Fmi3Status {
                set_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3FreeFMUState(c: Fmi3Instance, s: *mut Fmi3FmuState) -> Fmi3Status {
                free_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SerializedFMUStateSize(
                c: Fmi3Instance, s: Fmi3FmuState, size: *mut usize,
            ) -> Fmi3Status {
                serialized_fmu_state_size::<M>(c, s, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SerializeFMUState(
                c: Fmi3Instance, s: Fmi3FmuState, b: *mut Fmi3Byte, size: usize,
            ) -> Fmi3Status {
                serialize_fmu_state::<M>(c, s, b, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3DeserializeFMUState(
                c: Fmi3Instance, b: *const Fmi3Byte, size: usize, s: *mut Fmi3FmuState,
            ) -> Fmi3Status {
                deserialize_fmu_state::<M>(c, b, size, s)
            }

            // ---- partial derivatives
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetDirectionalDerivative(
                c: Fmi3Instance, u: *const Fmi3ValueReference, nu: usize,
                k: *const Fmi3ValueReference, nk: usize, seed: *const Fmi3Float64,
                ns: usize, sens: *mut Fmi3Float64, nsens: usize,
            ) -> Fmi3Status {
                let raw = RawDerivativeArgs {
                    unknowns: (u, nu), knowns: (k, nk), seed: (seed, ns), sensitivity: (sens, nsens),
                };
                get_directional_derivative::<M>(c, raw)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetAdjointDerivative(
                c: Fmi3Instance, u: *const Fmi3ValueReference, nu: usize,
                k: *const Fmi3ValueReference, nk: usize, seed: *const Fmi3Float64,
                ns: usize, sens: *mut Fmi3Float64, nsens: usize,
            ) -> Fmi3Status {
                let raw = RawDerivativeArgs {
                    unknowns: (u, nu), knowns: (k, nk), seed: (seed, ns), sensitivity: (sens, nsens),
                };
                get_adjoint_derivative::<M>(c, raw)
            }

            // ---- configuration mode: no structural parameters
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterConfigurationMode(c: Fmi3Instance) -> Fmi3Status {
                unsupported::<M>(c, "fmi3EnterConfigurationMode", "this FMU has no structural parameters")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3ExitConfigurationMode(c: Fmi3Instance) -> Fmi3Status {
                unsupported::<M>(c, "fmi3ExitConfigurationMode", "this FMU has no structural parameters")
            }

            // ---- clocks
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetIntervalDecimal(
                c: Fmi3Instance, _vr: *const Fmi3ValueReference, _n: usize,
                _intervals: *mut Fmi3Float64, _q: *mut Fmi3IntervalQualifier,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3GetIntervalDecimal", NO_CLOCKS)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetIntervalFraction(
                c: Fmi3Instance, _vr: *const Fmi3ValueReference, _n: usize,
                _counters: *mut Fmi3UInt64, _res: *mut Fmi3UInt64, _q: *mut Fmi3IntervalQualifier,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3GetIntervalFraction", NO_CLOCKS)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetShiftDecimal(
                c: Fmi3Instance, _vr: *const Fmi3ValueReference, _n: usize, _shifts: *mut Fmi3Float64,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3GetShiftDecimal", NO_CLOCKS)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetShiftFraction(
                c: Fmi3Instance, _vr: *const Fmi3ValueReference, _n: usize,
                _counters: *mut Fmi3UInt64, _res: *mut Fmi3UInt64,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3GetShiftFraction", NO_CLOCKS)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetIntervalDecimal(
                c: Fmi3Instance, _vr: *const Fmi3ValueReference, _n: usize, _intervals: *const Fmi3Float64,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3SetIntervalDecimal", NO_CLOCKS)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetIntervalFraction(
                c: Fmi3Instance, _vr: *const Fmi3ValueReference, _n: usize,
                _counters: *const Fmi3UInt64, _res: *const Fmi3UInt64,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3SetIntervalFraction", NO_CLOCKS)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetShiftDecimal(
                c: Fmi3Instance, _vr: *const Fmi3ValueReference, _n: usize, _shifts: *const Fmi3Float64,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3SetShiftDecimal", NO_CLOCKS)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetShiftFraction(
                c: Fmi3Instance, _vr: *const Fmi3ValueReference, _n: usize,
                _counters: *const Fmi3UInt64, _res: *const Fmi3UInt64,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3SetShiftFraction", NO_CLOCKS)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EvaluateDiscreteStates(c: Fmi3Instance) -> Fmi3Status {
                unsupported::<M>(c, "fmi3EvaluateDiscreteStates",
                    "not provided (providesEvaluateDiscreteStates=\"false\")")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3UpdateDiscreteStates(
                c: Fmi3Instance, need_update: *mut Fmi3Boolean, terminate: *mut Fmi3Boolean,
                nominals_changed: *mut Fmi3Boolean, values_changed: *mut Fmi3Boolean,
                next_defined: *mut Fmi3Boolean, next: *mut Fmi3Float64,
            ) -> Fmi3Status {
                let out = DiscreteStateOutputs {
                    need_update, terminate, nominals_changed, values_changed, next_defined, next,
                };
                update_discrete_states::<M>(c, out)
            }

            // ---- Model Exchange
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterContinuousTimeMode(c: Fmi3Instance) -> Fmi3Status {
                enter_continuous_time_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3CompletedIntegratorStep(
                c: Fmi3Instance, _no_set_prior: Fmi3Boolean, enter_event: *mut Fmi3Boolean,
                terminate: *mut Fmi3Boolean,
            ) -> Fmi3Status {
                completed_integrator_step::<M>(c, enter_event, terminate)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetTime(c: Fmi3Instance, t: Fmi3Float64) -> Fmi3Status {
                set_time::<M>(c, t)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetContinuousStates(
                c: Fmi3Instance, x: *const Fmi3Float64, n: usize,
            ) -> Fmi3Status {
                set_continuous_states::<M>(c, x, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetContinuousStateDerivatives(
                c: Fmi3Instance, dx: *mut Fmi3Float64, n: usize,
            ) -> Fmi3Status {
                get_continuous_state_derivatives::<M>(c, dx, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetEventIndicators(
                c: Fmi3Instance, z: *mut Fmi3Float64, n: usize,
            ) -> Fmi3Status {
                get_event_indicators::<M>(c, z, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetContinuousStates(
                c: Fmi3Instance, x: *mut Fmi3Float64, n: usize,
            ) -> Fmi3Status {
                get_continuous_states::<M>(c, x, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetNominalsOfContinuousStates(
                c: Fmi3Instance, nominals: *mut Fmi3Float64, n: usize,
            ) -> Fmi3Status {
                get_nominals_of_continuous_states::<M>(c, nominals, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetNumberOfEventIndicators(
                c: Fmi3Instance, n: *mut usize,
            ) -> Fmi3Status {
                get_number_of::<M>(c, "fmi3GetNumberOfEventIndicators", true, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetNumberOfContinuousStates(
                c: Fmi3Instance, n: *mut usize,
            ) -> Fmi3Status {
                get_number_of::<M>(c, "fmi3GetNumberOfContinuousStates", false, n)
            }

            // ---- Co-Simulation
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterStepMode(c: Fmi3Instance) -> Fmi3Status {
                unsupported::<M>(c, "fmi3EnterStepMode",
                    "only for Co-Simulation with eventModeUsed = true, which this FMU does not offer (Exit Initialization Mode enters Step Mode)")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetOutputDerivatives(
                c: Fmi3Instance, _vr: *const Fmi3ValueReference, _n: usize,
                _orders: *const Fmi3Int32, _v: *mut Fmi3Float64, _nv: usize,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3GetOutputDerivatives",
                    "output derivatives are not provided (maxOutputDerivativeOrder=\"0\")")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3DoStep(
                c: Fmi3Instance, t: Fmi3Float64, h: Fmi3Float64, _no_set_prior: Fmi3Boolean,
                event_handling_needed: *mut Fmi3Boolean, terminate_simulation: *mut Fmi3Boolean,
                early_return: *mut Fmi3Boolean, last_successful_time: *mut Fmi3Float64,
            ) -> Fmi3Status {
                let outputs = StepOutputs {
                    event_handling_needed, terminate_simulation, early_return, last_successful_time,
                };
                do_step::<M>(c, t, h, outputs)
            }

            // ---- Scheduled Execution
            #[no_mangle]
            pub unsafe extern "C" fn fmi3ActivateModelPartition(
                c: Fmi3Instance, _clock: Fmi3ValueReference, _t: Fmi3Float64,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3ActivateModelPartition",
                    "Scheduled Execution is not offered by this FMU")
            }
        }
    };
}

/// One getter or setter of a type without variables (used by [`export_fmi3!`]).
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi3_no_type {
    ($name:ident, $ty:literal, $values:ty, $call:ident) => {
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            c: Fmi3Instance,
            vr: *const Fmi3ValueReference,
            nvr: usize,
            _v: $values,
            nv: usize,
        ) -> Fmi3Status {
            let call = $crate::calls::$call(stringify!($name));
            no_variables_of_type::<M>(c, call, $ty, (vr, nvr), nv)
        }
    };
}
