//! [`export_model!`]: the `#[no_mangle] extern "C"` symbols of every FMI 2.0 function, each a
//! one-line call to the generic function of the same name in [`crate::ffi`], [`crate::me`] or
//! [`crate::states`].

/// Export every FMI 2.0 function (Model Exchange and Co-Simulation) for model type `$model` from this `cdylib`.
#[macro_export]
macro_rules! export_model {
    ($model:ty) => {
        /// The exported model type, named where the macro is invoked (so a bare name resolves).
        type Fmi2ExportedModel = $model;

        mod fmi2_exports {
            #![allow(non_snake_case, unused_imports, clippy::missing_safety_doc)]
            use super::Fmi2ExportedModel as M;
            use $crate::ffi::*;
            use $crate::me::*;
            use $crate::states::*;

            #[no_mangle]
            pub extern "C" fn fmi2GetTypesPlatform() -> Fmi2String {
                get_types_platform()
            }
            #[no_mangle]
            pub extern "C" fn fmi2GetVersion() -> Fmi2String {
                get_version()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetDebugLogging(
                c: Fmi2Component,
                on: Fmi2Boolean,
                n: usize,
                cats: *const Fmi2String,
            ) -> Fmi2Status {
                set_debug_logging::<M>(c, on, n, cats)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Instantiate(
                name: Fmi2String,
                ty: Fmi2Type,
                guid: Fmi2String,
                _resources: Fmi2String,
                f: *const Fmi2CallbackFunctions,
                _visible: Fmi2Boolean,
                logging: Fmi2Boolean,
            ) -> Fmi2Component {
                instantiate::<M>(name, ty, guid, f, logging)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeInstance(c: Fmi2Component) {
                free_instance::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetupExperiment(
                c: Fmi2Component,
                tol_defined: Fmi2Boolean,
                tol: Fmi2Real,
                start: Fmi2Real,
                stop_defined: Fmi2Boolean,
                stop: Fmi2Real,
            ) -> Fmi2Status {
                setup_experiment::<M>(c, tol_defined, tol, start, stop_defined, stop)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Fmi2Component) -> Fmi2Status {
                enter_initialization_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Fmi2Component) -> Fmi2Status {
                exit_initialization_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Terminate(c: Fmi2Component) -> Fmi2Status {
                terminate::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Reset(c: Fmi2Component) -> Fmi2Status {
                reset::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetReal(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *mut Fmi2Real,
            ) -> Fmi2Status {
                get_real::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetInteger(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *mut Fmi2Integer,
            ) -> Fmi2Status {
                get_integer::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBoolean(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *mut Fmi2Boolean,
            ) -> Fmi2Status {
                get_boolean::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetString(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *mut Fmi2String,
            ) -> Fmi2Status {
                get_string::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetReal(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *const Fmi2Real,
            ) -> Fmi2Status {
                set_real::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetInteger(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *const Fmi2Integer,
            ) -> Fmi2Status {
                set_integer::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetBoolean(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *const Fmi2Boolean,
            ) -> Fmi2Status {
                set_boolean::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetString(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *const Fmi2String,
            ) -> Fmi2Status {
                set_string::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetFMUstate(
                c: Fmi2Component,
                s: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                get_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetFMUstate(
                c: Fmi2Component,
                s: Fmi2FmuState,
            ) -> Fmi2Status {
                set_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeFMUstate(
                c: Fmi2Component,
                s: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                free_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
                c: Fmi2Component,
                s: Fmi2FmuState,
                size: *mut usize,
            ) -> Fmi2Status {
                serialized_fmu_state_size::<M>(c, s, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializeFMUstate(
                c: Fmi2Component,
                s: Fmi2FmuState,
                b: *mut Fmi2Byte,
                size: usize,
            ) -> Fmi2Status {
                serialize_fmu_state::<M>(c, s, b, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
                c: Fmi2Component,
                b: *const Fmi2Byte,
                size: usize,
                s: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                deserialize_fmu_state::<M>(c, b, size, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
                c: Fmi2Component,
                unknowns: *const Fmi2ValueReference,
                n_unknown: usize,
                knowns: *const Fmi2ValueReference,
                n_known: usize,
                dv_known: *const Fmi2Real,
                dv_unknown: *mut Fmi2Real,
            ) -> Fmi2Status {
                get_directional_derivative::<M>(
                    c, unknowns, n_unknown, knowns, n_known, dv_known, dv_unknown,
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
                c: Fmi2Component,
                _vr: *const Fmi2ValueReference,
                _n: usize,
                _order: *const Fmi2Integer,
                _v: *const Fmi2Real,
            ) -> Fmi2Status {
                unsupported::<M>(
                    c,
                    "fmi2SetRealInputDerivatives",
                    "inputs are not interpolated (canInterpolateInputs=\"false\")",
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
                c: Fmi2Component,
                _vr: *const Fmi2ValueReference,
                _n: usize,
                _order: *const Fmi2Integer,
                _v: *mut Fmi2Real,
            ) -> Fmi2Status {
                unsupported::<M>(
                    c,
                    "fmi2GetRealOutputDerivatives",
                    "output derivatives are not provided (maxOutputDerivativeOrder=\"0\")",
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DoStep(
                c: Fmi2Component,
                t: Fmi2Real,
                h: Fmi2Real,
                no_set_prior: Fmi2Boolean,
            ) -> Fmi2Status {
                do_step::<M>(c, t, h, no_set_prior)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2CancelStep(c: Fmi2Component) -> Fmi2Status {
                unsupported::<M>(
                    c,
                    "fmi2CancelStep",
                    "steps are never asynchronous (canRunAsynchronuously=\"false\")",
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2Status,
            ) -> Fmi2Status {
                get_status::<M>(c, "fmi2GetStatus", k, v.is_null())
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2Real,
            ) -> Fmi2Status {
                get_real_status::<M>(c, k, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetIntegerStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2Integer,
            ) -> Fmi2Status {
                get_status::<M>(c, "fmi2GetIntegerStatus", k, v.is_null())
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBooleanStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2Boolean,
            ) -> Fmi2Status {
                get_boolean_status::<M>(c, k, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetTime(c: Fmi2Component, t: Fmi2Real) -> Fmi2Status {
                set_time::<M>(c, t)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetContinuousStates(
                c: Fmi2Component,
                x: *const Fmi2Real,
                nx: usize,
            ) -> Fmi2Status {
                set_continuous_states::<M>(c, x, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterEventMode(c: Fmi2Component) -> Fmi2Status {
                enter_event_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2NewDiscreteStates(
                c: Fmi2Component,
                info: *mut Fmi2EventInfo,
            ) -> Fmi2Status {
                new_discrete_states::<M>(c, info)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterContinuousTimeMode(c: Fmi2Component) -> Fmi2Status {
                enter_continuous_time_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2CompletedIntegratorStep(
                c: Fmi2Component,
                no_set_prior: Fmi2Boolean,
                enter_event_mode: *mut Fmi2Boolean,
                terminate: *mut Fmi2Boolean,
            ) -> Fmi2Status {
                completed_integrator_step::<M>(c, no_set_prior, enter_event_mode, terminate)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDerivatives(
                c: Fmi2Component,
                dx: *mut Fmi2Real,
                nx: usize,
            ) -> Fmi2Status {
                get_derivatives::<M>(c, dx, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetEventIndicators(
                c: Fmi2Component,
                z: *mut Fmi2Real,
                ni: usize,
            ) -> Fmi2Status {
                get_event_indicators::<M>(c, z, ni)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetContinuousStates(
                c: Fmi2Component,
                x: *mut Fmi2Real,
                nx: usize,
            ) -> Fmi2Status {
                get_continuous_states::<M>(c, x, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetNominalsOfContinuousStates(
                c: Fmi2Component,
                n: *mut Fmi2Real,
                nx: usize,
            ) -> Fmi2Status {
                get_nominals_of_continuous_states::<M>(c, n, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStringStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2String,
            ) -> Fmi2Status {
                get_status::<M>(c, "fmi2GetStringStatus", k, v.is_null())
            }
        }
    };
}
