"""Saving and loading models and results: :func:`save` and :func:`load`.

One ``.npz`` file holds plain arrays and one JSON document (member ``__sdctrl__``, UTF-8 bytes)
that names the type, the format version and every field; nothing is pickled and loading never
executes code (``allow_pickle=False``, readers in :mod:`sdctrl._lib.npzfile`).  A round trip is
exact: arrays bit for bit with their dtypes, labels, tuples, floats (``nan``/``inf`` included) and
the ``info`` dicts.

Values are encoded recursively: ``None``, ``bool``, ``int``, ``str`` and finite ``float`` as JSON;
every other value as a JSON object with one key naming its kind -- ``{"array": member}`` (an
ndarray stored as its own member), ``{"scalar": member}`` (a numpy scalar, stored as a 0-d
array), ``{"float": "nan" | "inf" | "-inf"}``, ``{"complex": [re, im]}``, ``{"tuple": [...]}``,
``{"dict": {...}}`` (string keys), ``{"csr": {...}}`` (a ``scipy.sparse`` matrix, stored in CSR
form) and ``{"object": [type_name, {field: value}]}`` (a registered type).  JSON lists are lists.

What cannot be stored: in an ``info`` dict (diagnostics), a value of another type (a callable, an
exception, a set, an object of an unregistered class) is dropped -- a dict entry is left out, a
list or tuple item becomes ``None`` -- with one warning at :func:`save` naming each.  Subclasses
of ``dict``, ``list`` and ``tuple`` come back as the base type.  Anywhere else (a model's own
fields) an unstorable value is a ``TypeError``.

Registry
--------
Each storable type has a :class:`Codec`: its name in files, the class (imported lazily), a
function giving its fields and a function building it from them (validating them like its
constructor does), and the dtype kinds allowed for its array fields.  A new result type registers
itself with one call, usually::

    register_attrs("RobustResult", "sdctrl.robust._stability:RobustResult",
                   kinds={"worst_delta": "f", "mu_freq": "f", "mu": "f"}, build=_build_robust)

(fields read from the dataclass; ``build``, or else the constructor, validates them: see
:mod:`sdctrl.storage._builtin` and, for the results of FE updating,
:mod:`sdctrl.storage._update_codecs`) or, for full control,
``register(Codec(name, cls, to_fields, from_fields, kinds))``.  Names are never reused for another
type: files written today must load tomorrow.
"""

from __future__ import annotations

# importing builtin and results registers the built-in types and those of FE updating
from sdctrl.storage import _builtin as builtin
from sdctrl.storage import _update_codecs as results
from sdctrl.storage._archive import FORMAT_VERSION, StorageWarning, load, save
from sdctrl.storage._registry import Codec, register, register_attrs, registered

__all__ = ["FORMAT_VERSION", "Codec", "StorageWarning", "load", "register", "register_attrs",
           "registered", "save"]
