/* FMI 2.0 interface (model exchange and co-simulation) of the example oscillator FMU.
 *
 * Built by build_oscillator_fmu.py with the FMI 2.0 headers that FMPy ships. Importers bind
 * every function of the standard when they load the library, so the functions this FMU does
 * not support exist too and return fmi2Error.
 */
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "oscillator.h"

typedef struct {
    Oscillator model;
    fmi2Type type;
    char name[128];
    fmi2CallbackFunctions callbacks;
} Instance;

static void log_error(Instance *instance, const char *message) {
    if (instance->callbacks.logger)
        instance->callbacks.logger(instance->callbacks.componentEnvironment, instance->name,
                                   fmi2Error, "logStatusError", "%s", message);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    (void)c; (void)loggingOn; (void)nCategories; (void)categories;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    (void)fmuGUID; (void)fmuResourceLocation; (void)visible; (void)loggingOn;
    Instance *instance = calloc(1, sizeof(Instance));
    if (!instance) return NULL;
    instance->type = fmuType;
    strncpy(instance->name, instanceName ? instanceName : "oscillator", sizeof instance->name - 1);
    if (functions) instance->callbacks = *functions;
    oscillator_defaults(&instance->model);
    return instance;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    Instance *instance = c;
    instance->model.start_time = startTime;
    instance->model.time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Instance *instance = c;
    char why[256];
    if (oscillator_invalid(&instance->model, why, sizeof why)) {
        log_error(instance, why);
        return fmi2Error;
    }
    oscillator_closed_form(&instance->model); /* the initial state: x0 at rest */
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component c) {
    Instance *instance = c;
    oscillator_defaults(&instance->model);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    Instance *instance = c;
    for (size_t i = 0; i < nvr; i++)
        if (!oscillator_get(&instance->model, vr[i], &value[i])) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    Instance *instance = c;
    for (size_t i = 0; i < nvr; i++)
        if (!oscillator_set(&instance->model, vr[i], value[i])) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    Instance *instance = c;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] != VR_ORDER) return fmi2Error;
        value[i] = instance->model.order;
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    Instance *instance = c;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] != VR_ORDER) return fmi2Error;
        instance->model.order = value[i];
    }
    return fmi2OK;
}

/* ---- model exchange ---- */
fmi2Status fmi2EnterEventMode(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    (void)c;
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = fmi2False;
    info->nextEventTimeDefined = fmi2False;
    info->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode,
                                       fmi2Boolean *terminateSimulation) {
    (void)c; (void)noSetFMUStatePriorToCurrentPoint;
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    ((Instance *)c)->model.time = time;
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    Instance *instance = c;
    if (nx != 2) return fmi2Error;
    instance->model.x = x[0];
    instance->model.v = x[1];
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    Instance *instance = c;
    if (nx != 2) return fmi2Error;
    oscillator_derivatives(&instance->model, &derivatives[0], &derivatives[1]);
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    (void)c; (void)eventIndicators;
    return ni == 0 ? fmi2OK : fmi2Error;
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    Instance *instance = c;
    if (nx != 2) return fmi2Error;
    x[0] = instance->model.x;
    x[1] = instance->model.v;
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    (void)c;
    for (size_t i = 0; i < nx; i++) x_nominal[i] = 1.0;
    return fmi2OK;
}

/* ---- co-simulation: the closed form at the end of each communication step ---- */
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    Instance *instance = c;
    instance->model.time = currentCommunicationPoint + communicationStepSize;
    oscillator_closed_form(&instance->model);
    return fmi2OK;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)c; (void)s;
    *value = fmi2OK;
    return fmi2OK;
}

/* ---- not supported (declared by the standard, never needed by this FMU) ---- */
#define UNSUPPORTED (void)c; return fmi2Error
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) { (void)vr; (void)nvr; (void)value; UNSUPPORTED; }
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) { (void)vr; (void)nvr; (void)value; UNSUPPORTED; }
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) { (void)vr; (void)nvr; (void)value; UNSUPPORTED; }
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) { (void)vr; (void)nvr; (void)value; UNSUPPORTED; }
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)s; UNSUPPORTED; }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { (void)s; UNSUPPORTED; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)s; UNSUPPORTED; }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size) {
    (void)s; (void)size; UNSUPPORTED;
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t size) {
    (void)s; (void)b; (void)size; UNSUPPORTED;
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t size,
                                   fmi2FMUstate *s) { (void)b; (void)size; (void)s; UNSUPPORTED; }
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference k[], size_t nk,
                                        const fmi2Real dk[], fmi2Real du[]) {
    (void)u; (void)nu; (void)k; (void)nk; (void)dk; (void)du; UNSUPPORTED;
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value; UNSUPPORTED;
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value; UNSUPPORTED;
}
fmi2Status fmi2CancelStep(fmi2Component c) { UNSUPPORTED; }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    (void)s; (void)value; UNSUPPORTED;
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s; (void)value; UNSUPPORTED;
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    (void)s; (void)value; UNSUPPORTED;
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s; (void)value; UNSUPPORTED;
}
