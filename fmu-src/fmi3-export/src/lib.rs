//! Generic FMI 3.0 Co-Simulation export over the models of `fmi2-export`.
//!
//! The model is the same [`fmi2_export::Model`] (variables, `do_step` with its internal solver
//! and controllers); the state machine, argument checks, tolerance handling and FMU-state
//! serialization are the version-neutral [`fmi2_export::Instance`]. This crate adds the FMI 3.0 C
//! ABI ([`c`], [`ffi`]), [`export_fmi3!`] emitting all 75 `fmi3*` functions, and the FMI 3.0
//! `modelDescription.xml` ([`xml`]) from the same variable table. It knows no physics.
//!
//! A model's FMI 3.0 binary is a separate `cdylib` crate that links the model's `rlib` with its
//! `fmi2` feature off (so the binary exports the `fmi3*` functions only) and calls
//! `export_fmi3!`.

pub use fmi2_export;

pub mod c;
pub mod ffi;
pub mod me;
pub mod xml;

/// Value reference of `time`, the independent variable FMI 3.0 requires (FMI 3.0.2 section
/// 2.4.7.4: exactly one variable has `causality="independent"`). It lies far above every value
/// reference of the models' tables, which the test `export_fmi3!` adds checks.
pub const TIME_VALUE_REFERENCE: u32 = 1_000_000;

/// Value reference of the first event indicator, `eventIndicator[1]` (indicator `k`, from 0, has
/// `EVENT_INDICATOR_VALUE_REFERENCE + k`). FMI 3.0.2 section 2.4.8 lists event indicators as
/// variables (`<EventIndicator valueReference=...>`); the models' tables do not hold them, so this
/// layer adds them as continuous Float64 locals, read through `fmi3GetFloat64`.
pub const EVENT_INDICATOR_VALUE_REFERENCE: u32 = 1_000_001;

/// The documentation page of the FMI 3.0 archive: the model's page (the same model, variables and
/// value references as in FMI 2.0) with the FMI 3.0 interface line, and a note that maps the FMI
/// 2.0 function names the model's text uses onto their FMI 3.0 counterparts.
pub fn documentation<M: fmi2_export::Model>() -> String {
    let html = fmi2_export::html::documentation::<M>();
    let token = fmi2_export::xml::guid::<M>();
    let interfaces = fmi2_export::html::escape(&fmi2_export::html::interfaces::<M>());
    let fmi3 = format!(
        "<p>FMI 3.0 {interfaces}, instantiationToken <code>{token}</code> (the model is also \
         shipped as FMI 2.0, with the same variables and value references, plus <code>time</code>, \
         value reference {TIME_VALUE_REFERENCE}).</p>\n<p>Where this page names an FMI 2.0 \
         function, the FMI 3.0 one applies: <code>fmi2SetupExperiment</code> and \
         <code>fmi2EnterInitializationMode</code> are <code>fmi3EnterInitializationMode</code>, \
         <code>fmi2ExitInitializationMode</code> is <code>fmi3ExitInitializationMode</code>, \
         <code>fmi2GetReal</code>/<code>fmi2SetReal</code> are \
         <code>fmi3GetFloat64</code>/<code>fmi3SetFloat64</code>, \
         <code>fmi2NewDiscreteStates</code> is <code>fmi3UpdateDiscreteStates</code> and \
         <code>fmi2GetDerivatives</code> is <code>fmi3GetContinuousStateDerivatives</code>.</p>\n"
    );
    let fmi2 = fmi2_export::html::interface_line::<M>();
    if let Some(i) = html.find(&fmi2) {
        return format!("{}{fmi3}{}", &html[..i], &html[i + fmi2.len()..]);
    }
    match html.find("</h1>\n") {
        Some(i) => format!("{}{fmi3}{}", &html[..i + 6], &html[i + 6..]),
        None => format!("{fmi3}{html}"),
    }
}

/// Entry point of each model's `describe3-<crate>` binary: writes the FMI 3.0
/// `modelDescription.xml` and `documentation/index.html` into the directory given as the only
/// argument (default `.`).
pub fn describe_main<M: fmi2_export::Model>() {
    let dir = std::env::args().nth(1).unwrap_or_else(|| ".".to_string());
    let dir = std::path::Path::new(&dir);
    let result = (|| -> std::io::Result<()> {
        std::fs::create_dir_all(dir.join("documentation"))?;
        std::fs::write(
            dir.join("modelDescription.xml"),
            xml::model_description::<M>(),
        )?;
        std::fs::write(
            dir.join("documentation").join("index.html"),
            documentation::<M>(),
        )?;
        Ok(())
    })();
    if let Err(e) = result {
        eprintln!(
            "describe (FMI 3.0) {}: cannot write to {}: {e}",
            M::NAME,
            dir.display()
        );
        std::process::exit(2);
    }
}

/// Export all 75 FMI 3.0 functions for model type `$model` from this `cdylib`. Co-Simulation and
/// (for a model with `ModelExchange`) Model Exchange, with directional and adjoint derivatives in
/// both (for a model with an analytic Jacobian), are implemented; Scheduled Execution, Event
/// Mode in Co-Simulation, clocks, configuration mode, intermediate update and per-element
/// dependencies return `fmi3Error` with a logged reason.
#[macro_export]
macro_rules! export_fmi3 {
    ($model:ty) => {
        mod fmi3_exports {
            #![allow(non_snake_case, unused_imports, clippy::missing_safety_doc, clippy::too_many_arguments)]
            use $crate::c::*;
            use $crate::ffi::*;
            use $crate::me::*;
            use std::ffi::c_void;
            type M = $model;

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
                instantiate_model_exchange::<M>(name, token, logging, env, log)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
                name: Fmi3String, token: Fmi3String, _resources: Fmi3String,
                _visible: Fmi3Boolean, logging: Fmi3Boolean, event_mode_used: Fmi3Boolean,
                _early_return_allowed: Fmi3Boolean, _required: *const Fmi3ValueReference,
                n_required: usize, env: Fmi3InstanceEnvironment, log: Fmi3LogMessageCallback,
                _intermediate_update: Fmi3IntermediateUpdateCallback,
            ) -> Fmi3Instance {
                instantiate_co_simulation::<M>(name, token, event_mode_used, n_required, logging, env, log)
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
                enter_initialization_mode::<M>(c, tol_defined, tol, start, stop_defined, stop)
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
            $crate::__fmi3_no_type!(fmi3GetFloat32, "Float32", *mut Fmi3Float32, GET);
            $crate::__fmi3_no_type!(fmi3GetInt8, "Int8", *mut Fmi3Int8, GET);
            $crate::__fmi3_no_type!(fmi3GetUInt8, "UInt8", *mut Fmi3UInt8, GET);
            $crate::__fmi3_no_type!(fmi3GetInt16, "Int16", *mut Fmi3Int16, GET);
            $crate::__fmi3_no_type!(fmi3GetUInt16, "UInt16", *mut Fmi3UInt16, GET);
            $crate::__fmi3_no_type!(fmi3GetUInt32, "UInt32", *mut Fmi3UInt32, GET);
            $crate::__fmi3_no_type!(fmi3GetInt64, "Int64", *mut Fmi3Int64, GET);
            $crate::__fmi3_no_type!(fmi3GetUInt64, "UInt64", *mut Fmi3UInt64, GET);
            $crate::__fmi3_no_type!(fmi3GetString, "String", *mut Fmi3String, GET);
            $crate::__fmi3_no_type!(fmi3SetFloat32, "Float32", *const Fmi3Float32, SET);
            $crate::__fmi3_no_type!(fmi3SetInt8, "Int8", *const Fmi3Int8, SET);
            $crate::__fmi3_no_type!(fmi3SetUInt8, "UInt8", *const Fmi3UInt8, SET);
            $crate::__fmi3_no_type!(fmi3SetInt16, "Int16", *const Fmi3Int16, SET);
            $crate::__fmi3_no_type!(fmi3SetUInt16, "UInt16", *const Fmi3UInt16, SET);
            $crate::__fmi3_no_type!(fmi3SetUInt32, "UInt32", *const Fmi3UInt32, SET);
            $crate::__fmi3_no_type!(fmi3SetInt64, "Int64", *const Fmi3Int64, SET);
            $crate::__fmi3_no_type!(fmi3SetUInt64, "UInt64", *const Fmi3UInt64, SET);
            $crate::__fmi3_no_type!(fmi3SetString, "String", *const Fmi3String, SET);
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetBinary(
                c: Fmi3Instance, vr: *const Fmi3ValueReference, nvr: usize,
                _sizes: *mut usize, _v: *mut Fmi3Binary, _nv: usize,
            ) -> Fmi3Status {
                no_variables_of_type::<M>(c, "fmi3GetBinary", "Binary", vr, nvr, allowed::GET)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetBinary(
                c: Fmi3Instance, vr: *const Fmi3ValueReference, nvr: usize,
                _sizes: *const usize, _v: *const Fmi3Binary, _nv: usize,
            ) -> Fmi3Status {
                no_variables_of_type::<M>(c, "fmi3SetBinary", "Binary", vr, nvr, allowed::SET)
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
                update_discrete_states::<M>(c, need_update, terminate, nominals_changed, values_changed, next_defined, next)
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
                do_step::<M>(c, t, h, event_handling_needed, terminate_simulation, early_return, last_successful_time)
            }

            // ---- Scheduled Execution
            #[no_mangle]
            pub unsafe extern "C" fn fmi3ActivateModelPartition(
                c: Fmi3Instance, _clock: Fmi3ValueReference, _t: Fmi3Float64,
            ) -> Fmi3Status {
                unsupported::<M>(c, "fmi3ActivateModelPartition",
                    "Scheduled Execution is not offered by this FMU")
            }

            /// `time` takes a value reference no variable of the table uses, and the table
            /// follows FMI 2.0 (and so the subset of FMI 3.0 the description uses).
            #[test]
            fn time_value_reference_is_free() {
                let table = <M as $crate::fmi2_export::Model>::variables();
                assert!(table.iter().all(|v| v.value_reference != $crate::TIME_VALUE_REFERENCE));
                assert!(table.iter().all(|v| v.value_reference < $crate::EVENT_INDICATOR_VALUE_REFERENCE));
                assert!(table.iter().all(|v| v.name != "time"));
            }
        }
    };
}

/// One getter or setter of a type without variables (used by [`export_fmi3!`]).
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi3_no_type {
    ($name:ident, $ty:literal, $values:ty, $mask:ident) => {
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            c: Fmi3Instance,
            vr: *const Fmi3ValueReference,
            nvr: usize,
            _v: $values,
            _nv: usize,
        ) -> Fmi3Status {
            no_variables_of_type::<M>(c, stringify!($name), $ty, vr, nvr, allowed::$mask)
        }
    };
}

#[cfg(test)]
mod tests {
    use super::documentation;
    use test_oscillator::Oscillator;

    #[test]
    fn the_documentation_names_fmi3_not_fmi2_as_its_interface() {
        let html = documentation::<Oscillator>();
        assert!(html.contains(
            "<p>FMI 3.0 Model Exchange (2 continuous states, 0 event indicators) and Co-Simulation"
        ));
        assert!(!html.contains(", GUID <code>"));
        assert_eq!(html.matches("<h1>").count(), 1);
    }
}
