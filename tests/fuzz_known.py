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

KNOWN: dict = {}
