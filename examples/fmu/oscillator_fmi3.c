/* FMI 3.0 interface (model exchange and co-simulation) of the example oscillator FMU.
 *
 * Built by build_oscillator_fmu.py with the FMI 3.0 headers that FMPy ships. The functions
 * implemented here are declared with the standard's function types (the compiler checks
 * their signatures); importers bind every function of the standard when they load the
 * library, so the others exist as stubs that return fmi3Error and are never called for
 * this FMU (it declares no clocks, binaries, strings, FMU state or derivatives).
 */
#include <stdlib.h>
#include <string.h>

#include "fmi3FunctionTypes.h"
#include "oscillator.h"

#define EXPORT __attribute__((visibility("default")))

typedef struct {
    Oscillator model;
    int co_simulation;
    char name[128];
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log;
} Instance;

EXPORT fmi3GetVersionTYPE fmi3GetVersion;
EXPORT fmi3SetDebugLoggingTYPE fmi3SetDebugLogging;
EXPORT fmi3InstantiateModelExchangeTYPE fmi3InstantiateModelExchange;
EXPORT fmi3InstantiateCoSimulationTYPE fmi3InstantiateCoSimulation;
EXPORT fmi3FreeInstanceTYPE fmi3FreeInstance;
EXPORT fmi3EnterInitializationModeTYPE fmi3EnterInitializationMode;
EXPORT fmi3ExitInitializationModeTYPE fmi3ExitInitializationMode;
EXPORT fmi3EnterEventModeTYPE fmi3EnterEventMode;
EXPORT fmi3TerminateTYPE fmi3Terminate;
EXPORT fmi3ResetTYPE fmi3Reset;
EXPORT fmi3GetFloat64TYPE fmi3GetFloat64;
EXPORT fmi3SetFloat64TYPE fmi3SetFloat64;
EXPORT fmi3GetInt32TYPE fmi3GetInt32;
EXPORT fmi3SetInt32TYPE fmi3SetInt32;
EXPORT fmi3UpdateDiscreteStatesTYPE fmi3UpdateDiscreteStates;
EXPORT fmi3EnterContinuousTimeModeTYPE fmi3EnterContinuousTimeMode;
EXPORT fmi3CompletedIntegratorStepTYPE fmi3CompletedIntegratorStep;
EXPORT fmi3SetTimeTYPE fmi3SetTime;
EXPORT fmi3SetContinuousStatesTYPE fmi3SetContinuousStates;
EXPORT fmi3GetContinuousStateDerivativesTYPE fmi3GetContinuousStateDerivatives;
EXPORT fmi3GetEventIndicatorsTYPE fmi3GetEventIndicators;
EXPORT fmi3GetContinuousStatesTYPE fmi3GetContinuousStates;
EXPORT fmi3GetNominalsOfContinuousStatesTYPE fmi3GetNominalsOfContinuousStates;
EXPORT fmi3GetNumberOfEventIndicatorsTYPE fmi3GetNumberOfEventIndicators;
EXPORT fmi3GetNumberOfContinuousStatesTYPE fmi3GetNumberOfContinuousStates;
EXPORT fmi3EnterStepModeTYPE fmi3EnterStepMode;
EXPORT fmi3DoStepTYPE fmi3DoStep;

static Instance *instantiate(fmi3String name, fmi3InstanceEnvironment environment,
                             fmi3LogMessageCallback log, int co_simulation) {
    Instance *instance = calloc(1, sizeof(Instance));
    if (!instance) return NULL;
    strncpy(instance->name, name ? name : "oscillator", sizeof instance->name - 1);
    instance->environment = environment;
    instance->log = log;
    instance->co_simulation = co_simulation;
    oscillator_defaults(&instance->model);
    return instance;
}

const char *fmi3GetVersion(void) { return "3.0"; }

fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    (void)c; (void)loggingOn; (void)nCategories; (void)categories;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String token,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment environment,
                                          fmi3LogMessageCallback logMessage) {
    (void)token; (void)resourcePath; (void)visible; (void)loggingOn;
    return instantiate(instanceName, environment, logMessage, 0);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String token,
                                         fmi3String resourcePath, fmi3Boolean visible,
                                         fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
                                         fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference required[], size_t nRequired,
                                         fmi3InstanceEnvironment environment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    (void)token; (void)resourcePath; (void)visible; (void)loggingOn; (void)eventModeUsed;
    (void)earlyReturnAllowed; (void)required; (void)nRequired; (void)intermediateUpdate;
    return instantiate(instanceName, environment, logMessage, 1);
}

void fmi3FreeInstance(fmi3Instance c) { free(c); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    Instance *instance = c;
    instance->model.start_time = startTime;
    instance->model.time = startTime;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    Instance *instance = c;
    char why[256];
    if (oscillator_invalid(&instance->model, why, sizeof why)) {
        if (instance->log) instance->log(instance->environment, fmi3Error, "logStatusError", why);
        return fmi3Error;
    }
    oscillator_closed_form(&instance->model); /* the initial state: x0 at rest */
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { (void)c; return fmi3OK; }

fmi3Status fmi3Reset(fmi3Instance c) {
    oscillator_defaults(&((Instance *)c)->model);
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                          fmi3Float64 values[], size_t nValues) {
    Instance *instance = c;
    if (nValues < nvr) return fmi3Error;
    for (size_t i = 0; i < nvr; i++)
        if (!oscillator_get(&instance->model, vr[i], &values[i])) return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                          const fmi3Float64 values[], size_t nValues) {
    Instance *instance = c;
    if (nValues < nvr) return fmi3Error;
    for (size_t i = 0; i < nvr; i++)
        if (!oscillator_set(&instance->model, vr[i], values[i])) return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                        fmi3Int32 values[], size_t nValues) {
    Instance *instance = c;
    if (nValues < nvr) return fmi3Error;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] != VR_ORDER) return fmi3Error;
        values[i] = instance->model.order;
    }
    return fmi3OK;
}

fmi3Status fmi3SetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                        const fmi3Int32 values[], size_t nValues) {
    Instance *instance = c;
    if (nValues < nvr) return fmi3Error;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] != VR_ORDER) return fmi3Error;
        instance->model.order = values[i];
    }
    return fmi3OK;
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation,
                                    fmi3Boolean *nominalsChanged, fmi3Boolean *valuesChanged,
                                    fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    (void)c;
    *discreteStatesNeedUpdate = fmi3False;
    *terminateSimulation = fmi3False;
    *nominalsChanged = fmi3False;
    *valuesChanged = fmi3False;
    *nextEventTimeDefined = fmi3False;
    *nextEventTime = 0.0;
    return fmi3OK;
}

/* ---- model exchange ---- */
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) { (void)c; return fmi3OK; }

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode,
                                       fmi3Boolean *terminateSimulation) {
    (void)c; (void)noSetFMUStatePriorToCurrentPoint;
    *enterEventMode = fmi3False;
    *terminateSimulation = fmi3False;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 time) {
    ((Instance *)c)->model.time = time;
    return fmi3OK;
}

fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 x[], size_t nx) {
    Instance *instance = c;
    if (nx != 2) return fmi3Error;
    instance->model.x = x[0];
    instance->model.v = x[1];
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 derivatives[],
                                             size_t nx) {
    Instance *instance = c;
    if (nx != 2) return fmi3Error;
    oscillator_derivatives(&instance->model, &derivatives[0], &derivatives[1]);
    return fmi3OK;
}

fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 indicators[], size_t ni) {
    (void)c; (void)indicators;
    return ni == 0 ? fmi3OK : fmi3Error;
}

fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t nx) {
    Instance *instance = c;
    if (nx != 2) return fmi3Error;
    x[0] = instance->model.x;
    x[1] = instance->model.v;
    return fmi3OK;
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 nominals[], size_t nx) {
    (void)c;
    for (size_t i = 0; i < nx; i++) nominals[i] = 1.0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) {
    (void)c;
    *n = 0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) {
    (void)c;
    *n = 2;
    return fmi3OK;
}

/* ---- co-simulation: the closed form at the end of each communication step ---- */
fmi3Status fmi3EnterStepMode(fmi3Instance c) { (void)c; return fmi3OK; }

fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    (void)noSetFMUStatePriorToCurrentPoint;
    Instance *instance = c;
    instance->model.time = currentCommunicationPoint + communicationStepSize;
    oscillator_closed_form(&instance->model);
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    *lastSuccessfulTime = instance->model.time;
    return fmi3OK;
}

/* ---- not supported: present because importers bind every function, never called ---- */
#define UNSUPPORTED(name) \
    EXPORT fmi3Status name(void); \
    fmi3Status name(void) { return fmi3Error; }
UNSUPPORTED(fmi3InstantiateScheduledExecution)
UNSUPPORTED(fmi3GetFloat32)
UNSUPPORTED(fmi3GetInt8)
UNSUPPORTED(fmi3GetUInt8)
UNSUPPORTED(fmi3GetInt16)
UNSUPPORTED(fmi3GetUInt16)
UNSUPPORTED(fmi3GetUInt32)
UNSUPPORTED(fmi3GetInt64)
UNSUPPORTED(fmi3GetUInt64)
UNSUPPORTED(fmi3GetBoolean)
UNSUPPORTED(fmi3GetString)
UNSUPPORTED(fmi3GetBinary)
UNSUPPORTED(fmi3GetClock)
UNSUPPORTED(fmi3SetFloat32)
UNSUPPORTED(fmi3SetInt8)
UNSUPPORTED(fmi3SetUInt8)
UNSUPPORTED(fmi3SetInt16)
UNSUPPORTED(fmi3SetUInt16)
UNSUPPORTED(fmi3SetUInt32)
UNSUPPORTED(fmi3SetInt64)
UNSUPPORTED(fmi3SetUInt64)
UNSUPPORTED(fmi3SetBoolean)
UNSUPPORTED(fmi3SetString)
UNSUPPORTED(fmi3SetBinary)
UNSUPPORTED(fmi3SetClock)
UNSUPPORTED(fmi3GetNumberOfVariableDependencies)
UNSUPPORTED(fmi3GetVariableDependencies)
UNSUPPORTED(fmi3GetFMUState)
UNSUPPORTED(fmi3SetFMUState)
UNSUPPORTED(fmi3FreeFMUState)
UNSUPPORTED(fmi3SerializedFMUStateSize)
UNSUPPORTED(fmi3SerializeFMUState)
UNSUPPORTED(fmi3DeserializeFMUState)
UNSUPPORTED(fmi3GetDirectionalDerivative)
UNSUPPORTED(fmi3GetAdjointDerivative)
UNSUPPORTED(fmi3EnterConfigurationMode)
UNSUPPORTED(fmi3ExitConfigurationMode)
UNSUPPORTED(fmi3GetIntervalDecimal)
UNSUPPORTED(fmi3GetIntervalFraction)
UNSUPPORTED(fmi3GetShiftDecimal)
UNSUPPORTED(fmi3GetShiftFraction)
UNSUPPORTED(fmi3SetIntervalDecimal)
UNSUPPORTED(fmi3SetIntervalFraction)
UNSUPPORTED(fmi3SetShiftDecimal)
UNSUPPORTED(fmi3SetShiftFraction)
UNSUPPORTED(fmi3EvaluateDiscreteStates)
UNSUPPORTED(fmi3GetOutputDerivatives)
UNSUPPORTED(fmi3ActivateModelPartition)
