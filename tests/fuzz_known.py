"""Known failures of the API fuzz (``test_api_fuzz.py``) in entry points owned by other work.

``(entry, argument, class) -> what happens``.  These classes are left out of the property test
and pinned by ``test_known_failure`` (a strict xfail): when an owner fixes one, that test fails
with "no longer fails", and its row is deleted here.  ``SDCTRL_FUZZ_SWEEP=1 pytest
tests/test_api_fuzz.py -k sweep`` tries every class of every row and lists new failures and
stale rows.  "unnamed": the error names none of the argument's names; "accepted": the contract
says the value must be refused.
"""

#: issue that owns each entry point's body
OWNER = {
    "ComplexModeModel.residue_std": 14,
    "FEModel.dof_index": 11,
    "FEModel.frf": 11,
    "FEModel.modes": 14,
    "FEModel.normal_mode_model": 11,
    "FEModel.point": 11,
    "FEModel.principal_static_modes": 11,
    "FEModel.static_correction": 11,
    "FEModel.static_response": 11,
    "FEModel.strut": 11,
    "NormalModeModel.modified": 17,
    "NormalModeModel.uncertain": 13,
    "NormalModeModel.with_feedback": 17,
    "Parameter": 11,
    "UncertainModel.frf_envelope": 13,
    "UncertainModel.perturbed": 13,
    "UncertainModel.perturbed_matrices": 13,
    "UncertainModel.perturbed_model": 13,
    "UncertainModel.sample": 13,
    "UncertainModel.sample_deltas": 13,
    "hybrid": 17,
    "identifiability": 11,
    "identify": 14,
    "initial_poles": 14,
    "normal_modes": 14,
    "robust_stability": 13,
    "testbed_frf": 11,
    "update": 11,
    "worst_case_gain": 13,
}

KNOWN: dict = {
    # issue 11 (fe/model.py, testbeds.py)
    ("FEModel.dof_index", "labels", "none"): "unnamed TypeError: 'NoneType' object is not iterable",
    ("FEModel.dof_index", "labels", "number"): "unnamed TypeError: 'float' object is not iterable",
    ("FEModel.frf", "c", "string"):
        "unnamed ValueError: unknown DOF label '1.0' (labels look like 'N0.x')",
    ("FEModel.frf", "freq", "huge"):
        "unnamed ValueError: H must contain only finite values (no NaN or inf)",
    ("FEModel.normal_mode_model", "c", "string"):
        "unnamed ValueError: unknown DOF label '1.0' (labels look like 'N0.x')",
    ("FEModel.normal_mode_model", "damping", "complex"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'complex'",
    ("FEModel.normal_mode_model", "damping", "string"): "accepted (returned a NormalModeModel)",
    ("FEModel.point", "direction", "none"):
        "unnamed ValueError: unknown DOF label 'N1' (labels look like 'N0.x')",
    ("FEModel.point", "dofs", "none"): "unnamed TypeError: 'NoneType' object is not iterable",
    ("FEModel.point", "dofs", "number"): "unnamed TypeError: 'float' object is not iterable",
    ("FEModel.principal_static_modes", "rtol", "array"): "accepted (returned a array)",
    ("FEModel.principal_static_modes", "rtol", "complex"): "accepted (returned a array)",
    ("FEModel.principal_static_modes", "rtol", "inf"): "accepted (returned a array)",
    ("FEModel.principal_static_modes", "rtol", "list"):
        "unnamed TypeError: can't multiply sequence by non-int of type 'numpy.float64'",
    ("FEModel.principal_static_modes", "rtol", "nan"): "accepted (returned a array)",
    ("FEModel.principal_static_modes", "rtol", "negative"): "accepted (returned a array)",
    ("FEModel.principal_static_modes", "rtol", "none"):
        "unnamed TypeError: unsupported operand type(s) for *: 'NoneType' and 'float'",
    ("FEModel.principal_static_modes", "rtol", "string"):
        "unnamed TypeError: can't multiply sequence by non-int of type 'numpy.float64'",
    ("FEModel.principal_static_modes", "rtol", "zero"): "accepted (returned a array)",
    ("Parameter", "description", "array"): "accepted (returned a Parameter)",
    ("Parameter", "description", "dict"): "accepted (returned a Parameter)",
    ("Parameter", "description", "list"): "accepted (returned a Parameter)",
    ("Parameter", "description", "number"): "accepted (returned a Parameter)",
    ("Parameter", "scale", "array"):
        "unnamed TypeError: only 0-dimensional arrays can be converted to Python scalars",
    ("Parameter", "scale", "complex"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'complex'",
    ("Parameter", "scale", "list"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'list'",
    ("Parameter", "scale", "negative"): "accepted (returned a Parameter)",
    ("Parameter", "scale", "string"): "accepted (returned a Parameter)",
    ("identifiability", "corr_max", "array"):
        "unnamed ValueError: The truth value of an array with more than one element is ambiguou",
    ("identifiability", "corr_max", "complex"):
        "unnamed TypeError: '<' not supported between instances of 'int' and 'complex'",
    ("identifiability", "corr_max", "list"):
        "unnamed TypeError: '<' not supported between instances of 'int' and 'list'",
    ("identifiability", "corr_max", "none"):
        "unnamed TypeError: '<' not supported between instances of 'int' and 'NoneType'",
    ("identifiability", "corr_max", "string"):
        "unnamed TypeError: '<' not supported between instances of 'int' and 'str'",
    ("identifiability", "damping", "huge"): "ill-formed result: ",
    ("identifiability", "fmax", "array"):
        "unnamed TypeError: only 0-dimensional arrays can be converted to Python scalars",
    ("identifiability", "fmax", "complex"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'complex'",
    ("identifiability", "fmax", "huge"):
        "unnamed ValueError: the reduced mass is not positive definite at p = [0.0]: narrow the",
    ("identifiability", "fmax", "list"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'list'",
    ("identifiability", "fmax", "string"): "accepted (returned a Identifiability)",
    ("identifiability", "freq", "huge"):
        "unnamed LinAlgError: singular matrix: resolution failed at diagonal 12",
    ("identifiability", "freq", "tiny"):
        "unnamed ValueError: Residuals are not finite in the initial point.",
    ("identifiability", "n_averages", "array"): "accepted (returned a Identifiability)",
    ("identifiability", "n_averages", "below"): "accepted (returned a Identifiability)",
    ("identifiability", "n_averages", "float"): "accepted (returned a Identifiability)",
    ("identifiability", "n_averages", "inf"): "accepted (returned a Identifiability)",
    ("identifiability", "n_averages", "nan"): "accepted (returned a Identifiability)",
    ("identifiability", "n_averages", "negative"): "accepted (returned a Identifiability)",
    ("identifiability", "n_averages", "none"): "accepted (returned a Identifiability)",
    ("identifiability", "n_averages", "string"): "accepted (returned a Identifiability)",
    ("identifiability", "noise", "array"):
        "unnamed TypeError: only 0-dimensional arrays can be converted to Python scalars",
    ("identifiability", "noise", "complex"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'complex'",
    ("identifiability", "noise", "list"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'list'",
    ("identifiability", "noise", "string"): "accepted (returned a Identifiability)",
    ("testbed_frf", "band", "huge"):
        "unnamed ValueError: the FRF overflows (NaN/inf from finite inputs): freq or the model'",
    ("testbed_frf", "noise", "array"):
        "unnamed TypeError: only 0-dimensional arrays can be converted to Python scalars",
    ("testbed_frf", "noise", "complex"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'complex'",
    ("testbed_frf", "noise", "list"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'list'",
    ("testbed_frf", "noise", "none"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'NoneType'",
    ("testbed_frf", "noise", "string"): "accepted (returned a FRF)",
    ("testbed_frf", "n", "huge"): "IndexError: index -1 is out of bounds for axis 0 with size 0",
    ("testbed_frf", "seed", "array"): "accepted (returned a FRF)",
    ("testbed_frf", "seed", "below"): "accepted (returned a FRF)",
    ("testbed_frf", "seed", "float"): "accepted (returned a FRF)",
    ("testbed_frf", "seed", "inf"): "accepted (returned a FRF)",
    ("testbed_frf", "seed", "nan"): "accepted (returned a FRF)",
    ("testbed_frf", "seed", "negative"): "accepted (returned a FRF)",
    ("testbed_frf", "seed", "string"): "accepted (returned a FRF)",
    ("update", "fmax", "array"):
        "unnamed ValueError: The truth value of an array with more than one element is ambiguou",
    ("update", "fmax", "complex"):
        "unnamed TypeError: '>' not supported between instances of 'complex' and 'int'",
    ("update", "fmax", "huge"):
        "unnamed ValueError: the reduced mass is not positive definite at p = [0.0]: narrow the",
    ("update", "fmax", "list"):
        "unnamed TypeError: '>' not supported between instances of 'list' and 'int'",
    ("update", "fmax", "string"):
        "unnamed TypeError: ufunc 'isfinite' not supported for the input types, and the inputs ",
    ("update", "freq", "huge"):
        "unnamed LinAlgError: singular matrix: resolution failed at diagonal 12",
    ("update", "freq", "tiny"):
        "unnamed ValueError: Residuals are not finite in the initial point.",
    ("update", "max_nfev", "array"):
        "unnamed TypeError: only 0-dimensional arrays can be converted to Python scalars",
    ("update", "max_nfev", "float"): "accepted (returned a UpdateResult)",
    ("update", "max_nfev", "inf"): "OverflowError: cannot convert float infinity to integer",
    ("update", "max_nfev", "nan"): "unnamed ValueError: cannot convert float NaN to integer",
    ("update", "max_nfev", "string"): "accepted (returned a UpdateResult)",
    # issue 13 (uncertainty.py, robust.py)
    # issue 14 (identification, fe/eigen.py)
    ("FEModel.modes", "sigma", "array"):
        "unnamed TypeError: only 0-dimensional arrays can be converted to Python scalars",
    ("FEModel.modes", "sigma", "complex"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'complex'",
    ("FEModel.modes", "sigma", "inf"):
        "accepted (the contract says refuse), returned (array([ 4.47972131, 8.73481069, 12.5519",
    ("FEModel.modes", "sigma", "list"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'list'",
    ("FEModel.modes", "sigma", "nan"):
        "accepted (the contract says refuse), returned (array([ 4.47972131, 8.73481069, 12.5519",
    ("FEModel.modes", "sigma", "string"):
        "accepted (the contract says refuse), returned (array([ 4.47972131, 8.73481069, 12.5519",
    ("initial_poles", "prominence", "inf"): "accepted (returned a array)",
    ("normal_modes", "poles", "huge"): "unnamed ValueError: array must not contain infs or NaNs",
    ("normal_modes", "poles", "tiny"): "OverflowError: (34, 'Numerical result out of range')",
    # issue 17 (hybridmodel.py)
    ("hybrid", "fmax", "array"):
        "unnamed TypeError: only 0-dimensional arrays can be converted to Python scalars",
    ("hybrid", "fmax", "complex"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'complex'",
    ("hybrid", "fmax", "list"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'list'",
    ("hybrid", "fmax", "string"): "accepted (returned a HybridModel)",
    ("hybrid", "mac_min", "array"):
        "unnamed TypeError: only 0-dimensional arrays can be converted to Python scalars",
    ("hybrid", "mac_min", "complex"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'complex'",
    ("hybrid", "mac_min", "inf"): "accepted (returned a HybridModel)",
    ("hybrid", "mac_min", "list"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'list'",
    ("hybrid", "mac_min", "nan"): "accepted (returned a HybridModel)",
    ("hybrid", "mac_min", "negative"): "accepted (returned a HybridModel)",
    ("hybrid", "mac_min", "none"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'NoneType'",
    ("hybrid", "mac_min", "string"): "accepted (returned a HybridModel)",
    ("hybrid", "sensor_c", "huge"): "unnamed ValueError: matrix contains invalid numeric entries",
    ("hybrid", "sensor_c", "tiny"):
        "unnamed ValueError: cphi must contain only finite values (no NaN or inf)",
}
