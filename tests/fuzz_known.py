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
    # issue 13 (uncertainty.py, robust.py)
    ("NormalModeModel.uncertain", "dGamma", "complex"): "accepted (returned a UncertainModel)",
    ("NormalModeModel.uncertain", "dGamma", "dict"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'dict'",
    ("NormalModeModel.uncertain", "dGamma", "string"):
        "unnamed ValueError: could not convert string to float: 'abc'",
    ("NormalModeModel.uncertain", "dGamma", "string_array"):
        "unnamed ValueError: could not convert string to float: np.str_('x')",
    ("NormalModeModel.uncertain", "dOmega", "complex"): "accepted (returned a UncertainModel)",
    ("NormalModeModel.uncertain", "dOmega", "dict"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'dict'",
    ("NormalModeModel.uncertain", "dOmega", "string"):
        "unnamed ValueError: could not convert string to float: 'abc'",
    ("NormalModeModel.uncertain", "dOmega", "string_array"):
        "unnamed ValueError: could not convert string to float: np.str_('x')",
    ("NormalModeModel.uncertain", "db", "complex"): "accepted (returned a UncertainModel)",
    ("NormalModeModel.uncertain", "db", "dict"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'dict'",
    ("NormalModeModel.uncertain", "db", "string"):
        "unnamed ValueError: could not convert string to float: 'abc'",
    ("NormalModeModel.uncertain", "db", "string_array"):
        "unnamed ValueError: could not convert string to float: np.str_('x')",
    ("NormalModeModel.uncertain", "dc", "complex"): "accepted (returned a UncertainModel)",
    ("NormalModeModel.uncertain", "dc", "dict"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'dict'",
    ("NormalModeModel.uncertain", "dc", "string"):
        "unnamed ValueError: could not convert string to float: 'abc'",
    ("NormalModeModel.uncertain", "dc", "string_array"):
        "unnamed ValueError: could not convert string to float: np.str_('x')",
    ("UncertainModel.frf_envelope", "max_vertices", "array"):
        "unnamed ValueError: The truth value of an array with more than one element is ambiguou",
    ("UncertainModel.frf_envelope", "max_vertices", "below"):
        "accepted (the contract says refuse), returned {'freq': array([0.1 , 0.22857143, 0.3571",
    ("UncertainModel.frf_envelope", "max_vertices", "bool"):
        "unnamed TypeError: an integer is required",
    ("UncertainModel.frf_envelope", "max_vertices", "float"):
        "accepted (the contract says refuse), returned {'freq': array([0.1 , 0.22857143, 0.3571",
    ("UncertainModel.frf_envelope", "max_vertices", "inf"):
        "accepted (the contract says refuse), returned {'freq': array([0.1 , 0.22857143, 0.3571",
    ("UncertainModel.frf_envelope", "max_vertices", "nan"):
        "unnamed TypeError: 'float' object cannot be interpreted as an integer",
    ("UncertainModel.frf_envelope", "max_vertices", "negative"):
        "unnamed ValueError: negative dimensions are not allowed",
    ("UncertainModel.frf_envelope", "max_vertices", "none"):
        "unnamed TypeError: '<=' not supported between instances of 'int' and 'NoneType'",
    ("UncertainModel.frf_envelope", "max_vertices", "string"):
        "unnamed TypeError: '<=' not supported between instances of 'int' and 'str'",
    ("UncertainModel.frf_envelope", "n_samples", "array"):
        "unnamed TypeError: only 0-dimensional arrays can be converted to Python scalars",
    ("UncertainModel.frf_envelope", "n_samples", "below"):
        "accepted (the contract says refuse), returned {'freq': array([0.1 , 0.22857143, 0.3571",
    ("UncertainModel.frf_envelope", "n_samples", "float"):
        "accepted (the contract says refuse), returned {'freq': array([0.1 , 0.22857143, 0.3571",
    ("UncertainModel.frf_envelope", "n_samples", "huge"):
        "unnamed ValueError: Maximum allowed dimension exceeded",
    ("UncertainModel.frf_envelope", "n_samples", "inf"):
        "OverflowError: cannot convert float infinity to integer",
    ("UncertainModel.frf_envelope", "n_samples", "nan"):
        "unnamed ValueError: cannot convert float NaN to integer",
    ("UncertainModel.frf_envelope", "n_samples", "negative"):
        "unnamed ValueError: negative dimensions are not allowed",
    ("UncertainModel.frf_envelope", "n_samples", "none"):
        "unnamed TypeError: int() argument must be a string, a bytes-like object or a real numb",
    ("UncertainModel.frf_envelope", "n_samples", "string"):
        "accepted (the contract says refuse), returned {'freq': array([0.1 , 0.22857143, 0.3571",
    ("UncertainModel.frf_envelope", "seed", "array"):
        "accepted (the contract says refuse), returned {'freq': array([0.1 , 0.22857143, 0.3571",
    ("UncertainModel.frf_envelope", "seed", "below"):
        "unnamed ValueError: expected non-negative integer",
    ("UncertainModel.frf_envelope", "seed", "float"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 0.5",
    ("UncertainModel.frf_envelope", "seed", "float_integral"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 0.0",
    ("UncertainModel.frf_envelope", "seed", "inf"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not inf",
    ("UncertainModel.frf_envelope", "seed", "nan"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not nan",
    ("UncertainModel.frf_envelope", "seed", "negative"):
        "unnamed ValueError: expected non-negative integer",
    ("UncertainModel.frf_envelope", "seed", "string"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 3",
    ("UncertainModel.perturbed_matrices", "deltas", "complex"):
        "accepted (the contract says refuse), returned (array([[9.8696044]]), array([[0.1413716",
    ("UncertainModel.perturbed_matrices", "deltas", "dict"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'dict'",
    ("UncertainModel.perturbed_matrices", "deltas", "huge"):
        "accepted (the contract says refuse), returned (array([[9.8696044]]), array([[1.5707963",
    ("UncertainModel.perturbed_matrices", "deltas", "inf"):
        "accepted (the contract says refuse), returned (array([[9.8696044]]), array([[inf]]), a",
    ("UncertainModel.perturbed_matrices", "deltas", "nan"):
        "accepted (the contract says refuse), returned (array([[9.8696044]]), array([[nan]]), a",
    ("UncertainModel.perturbed_matrices", "deltas", "ndim_down"):
        "accepted (the contract says refuse), returned (array([[9.8696044]]), array([[0.1413716",
    ("UncertainModel.perturbed_matrices", "deltas", "ndim_up"):
        "accepted (the contract says refuse), returned (array([[9.8696044]]), array([[0.1413716",
    ("UncertainModel.perturbed_matrices", "deltas", "none"):
        "accepted (the contract says refuse), returned (array([[9.8696044]]), array([[nan]]), a",
    ("UncertainModel.perturbed_matrices", "deltas", "object_none"):
        "accepted (the contract says refuse), returned (array([[9.8696044]]), array([[nan]]), a",
    ("UncertainModel.perturbed_matrices", "deltas", "string"):
        "unnamed ValueError: could not convert string to float: 'abc'",
    ("UncertainModel.perturbed_matrices", "deltas", "string_array"):
        "unnamed ValueError: could not convert string to float: np.str_('x')",
    ("UncertainModel.perturbed_model", "deltas", "complex"):
        "accepted (returned a NormalModeModel)",
    ("UncertainModel.perturbed_model", "deltas", "dict"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'dict'",
    ("UncertainModel.perturbed_model", "deltas", "huge"): "accepted (returned a NormalModeModel)",
    ("UncertainModel.perturbed_model", "deltas", "inf"):
        "unnamed ValueError: Gamma must contain only finite values (no NaN or inf)",
    ("UncertainModel.perturbed_model", "deltas", "nan"):
        "unnamed ValueError: Gamma must contain only finite values (no NaN or inf)",
    ("UncertainModel.perturbed_model", "deltas", "ndim_down"):
        "accepted (returned a NormalModeModel)",
    ("UncertainModel.perturbed_model", "deltas", "ndim_up"):
        "accepted (returned a NormalModeModel)",
    ("UncertainModel.perturbed_model", "deltas", "none"):
        "unnamed ValueError: Gamma must contain only finite values (no NaN or inf)",
    ("UncertainModel.perturbed_model", "deltas", "object_none"):
        "unnamed ValueError: Gamma must contain only finite values (no NaN or inf)",
    ("UncertainModel.perturbed_model", "deltas", "string"):
        "unnamed ValueError: could not convert string to float: 'abc'",
    ("UncertainModel.perturbed_model", "deltas", "string_array"):
        "unnamed ValueError: could not convert string to float: np.str_('x')",
    ("UncertainModel.perturbed", "deltas", "complex"): "accepted (returned a StateSpace)",
    ("UncertainModel.perturbed", "deltas", "dict"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'dict'",
    ("UncertainModel.perturbed", "deltas", "huge"): "accepted (returned a StateSpace)",
    ("UncertainModel.perturbed", "deltas", "inf"): "accepted (returned a StateSpace)",
    ("UncertainModel.perturbed", "deltas", "nan"): "accepted (returned a StateSpace)",
    ("UncertainModel.perturbed", "deltas", "ndim_down"): "accepted (returned a StateSpace)",
    ("UncertainModel.perturbed", "deltas", "ndim_up"): "accepted (returned a StateSpace)",
    ("UncertainModel.perturbed", "deltas", "none"): "accepted (returned a StateSpace)",
    ("UncertainModel.perturbed", "deltas", "object_none"): "accepted (returned a StateSpace)",
    ("UncertainModel.perturbed", "deltas", "string"):
        "unnamed ValueError: could not convert string to float: 'abc'",
    ("UncertainModel.perturbed", "deltas", "string_array"):
        "unnamed ValueError: could not convert string to float: np.str_('x')",
    ("UncertainModel.sample_deltas", "n", "below"): "accepted (returned a array)",
    ("UncertainModel.sample_deltas", "n", "float"): "accepted (returned a array)",
    ("UncertainModel.sample_deltas", "n", "inf"):
        "OverflowError: cannot convert float infinity to integer",
    ("UncertainModel.sample_deltas", "n", "string"): "accepted (returned a array)",
    ("UncertainModel.sample_deltas", "seed", "array"): "accepted (returned a array)",
    ("UncertainModel.sample_deltas", "seed", "below"):
        "unnamed ValueError: expected non-negative integer",
    ("UncertainModel.sample_deltas", "seed", "float"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 0.5",
    ("UncertainModel.sample_deltas", "seed", "float_integral"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 0.0",
    ("UncertainModel.sample_deltas", "seed", "inf"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not inf",
    ("UncertainModel.sample_deltas", "seed", "nan"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not nan",
    ("UncertainModel.sample_deltas", "seed", "negative"):
        "unnamed ValueError: expected non-negative integer",
    ("UncertainModel.sample_deltas", "seed", "string"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 3",
    ("UncertainModel.sample", "n", "below"): "accepted (the contract says refuse), returned []",
    ("UncertainModel.sample", "n", "float"):
        "accepted (the contract says refuse), returned [StateSpace(",
    ("UncertainModel.sample", "n", "inf"):
        "OverflowError: cannot convert float infinity to integer",
    ("UncertainModel.sample", "n", "string"):
        "accepted (the contract says refuse), returned [StateSpace(",
    ("UncertainModel.sample", "seed", "array"):
        "accepted (the contract says refuse), returned [StateSpace(",
    ("UncertainModel.sample", "seed", "below"): "unnamed ValueError: expected non-negative integer",
    ("UncertainModel.sample", "seed", "float"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 0.5",
    ("UncertainModel.sample", "seed", "float_integral"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 0.0",
    ("UncertainModel.sample", "seed", "inf"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not inf",
    ("UncertainModel.sample", "seed", "nan"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not nan",
    ("UncertainModel.sample", "seed", "negative"):
        "unnamed ValueError: expected non-negative integer",
    ("UncertainModel.sample", "seed", "string"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 3",
    ("robust_stability", "eps", "array"):
        "unnamed TypeError: only 0-dimensional arrays can be converted to Python scalars",
    ("robust_stability", "eps", "complex"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'complex'",
    ("robust_stability", "eps", "huge"): "unnamed LinAlgError: SVD did not converge",
    ("robust_stability", "eps", "list"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'list'",
    ("robust_stability", "eps", "none"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'NoneType'",
    ("robust_stability", "eps", "string"): "accepted (returned a RobustResult)",
    ("robust_stability", "executor", "array"):
        "AttributeError: 'numpy.ndarray' object has no attribute 'map'",
    ("robust_stability", "executor", "dict"):
        "AttributeError: 'dict' object has no attribute 'map'",
    ("robust_stability", "executor", "list"):
        "AttributeError: 'list' object has no attribute 'map'",
    ("robust_stability", "executor", "number"):
        "AttributeError: 'float' object has no attribute 'map'",
    ("robust_stability", "executor", "string"):
        "AttributeError: 'str' object has no attribute 'map'",
    ("robust_stability", "n_directions", "below"): "accepted (returned a RobustResult)",
    ("robust_stability", "n_directions", "huge"):
        "unnamed ValueError: Maximum allowed dimension exceeded",
    ("robust_stability", "rtol", "array"):
        "unnamed TypeError: only 0-dimensional arrays can be converted to Python scalars",
    ("robust_stability", "rtol", "complex"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'complex'",
    ("robust_stability", "rtol", "list"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'list'",
    ("robust_stability", "rtol", "none"):
        "unnamed TypeError: float() argument must be a string or a real number, not 'NoneType'",
    ("robust_stability", "rtol", "string"):
        "unnamed ValueError: could not convert string to float: 'abc'",
    ("robust_stability", "seed", "array"): "accepted (returned a RobustResult)",
    ("robust_stability", "seed", "below"): "unnamed ValueError: expected non-negative integer",
    ("robust_stability", "seed", "float"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 0.5",
    ("robust_stability", "seed", "float_integral"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 0.0",
    ("robust_stability", "seed", "inf"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not inf",
    ("robust_stability", "seed", "nan"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not nan",
    ("robust_stability", "seed", "negative"): "unnamed ValueError: expected non-negative integer",
    ("robust_stability", "seed", "string"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 3",
    ("worst_case_gain", "executor", "array"):
        "AttributeError: 'numpy.ndarray' object has no attribute 'map'",
    ("worst_case_gain", "executor", "dict"): "AttributeError: 'dict' object has no attribute 'map'",
    ("worst_case_gain", "executor", "list"): "AttributeError: 'list' object has no attribute 'map'",
    ("worst_case_gain", "executor", "number"):
        "AttributeError: 'float' object has no attribute 'map'",
    ("worst_case_gain", "executor", "string"):
        "AttributeError: 'str' object has no attribute 'map'",
    ("worst_case_gain", "n_samples", "array"):
        "unnamed TypeError: only 0-dimensional arrays can be converted to Python scalars",
    ("worst_case_gain", "n_samples", "below"):
        "accepted (the contract says refuse), returned {'freq': array([0.2 , 0.46666667, 0.7333",
    ("worst_case_gain", "n_samples", "float"):
        "accepted (the contract says refuse), returned {'freq': array([0.2 , 0.46666667, 0.7333",
    ("worst_case_gain", "n_samples", "huge"):
        "unnamed ValueError: Maximum allowed dimension exceeded",
    ("worst_case_gain", "n_samples", "inf"):
        "OverflowError: cannot convert float infinity to integer",
    ("worst_case_gain", "n_samples", "nan"):
        "unnamed ValueError: cannot convert float NaN to integer",
    ("worst_case_gain", "n_samples", "none"):
        "unnamed TypeError: int() argument must be a string, a bytes-like object or a real numb",
    ("worst_case_gain", "n_samples", "string"):
        "accepted (the contract says refuse), returned {'freq': array([0.2 , 0.46666667, 0.7333",
    ("worst_case_gain", "seed", "array"):
        "accepted (the contract says refuse), returned {'freq': array([0.2 , 0.46666667, 0.7333",
    ("worst_case_gain", "seed", "below"): "unnamed ValueError: expected non-negative integer",
    ("worst_case_gain", "seed", "float"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 0.5",
    ("worst_case_gain", "seed", "float_integral"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 0.0",
    ("worst_case_gain", "seed", "inf"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not inf",
    ("worst_case_gain", "seed", "nan"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not nan",
    ("worst_case_gain", "seed", "negative"): "unnamed ValueError: expected non-negative integer",
    ("worst_case_gain", "seed", "string"):
        "unnamed TypeError: SeedSequence expects int or sequence of ints for entropy not 3",
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
