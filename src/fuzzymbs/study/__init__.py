"""Studies: model + fuzzy parameters + method, executors, stores, resume."""
