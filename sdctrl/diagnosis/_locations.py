"""The caller's own list of candidate locations of a diagnosis (``diagnose(locations=...)``).

A user who knows where a change can be (the area of a repair, the bars of one bay, the nodes
an equipment was fixed to) scans only there: the candidate scan then grows with the
locations listed, not with the FE model (issue 27: 10^4 locations of a 10^5-DOF model).
A location is a node name (a mass change at the node and a resonator on each of its
translations) or a pair of node names (a dashpot and a stiffness change between them, along
the pair's axis: an element's or any other pair's, 5.4).
"""

from __future__ import annotations

import numpy as np

__all__ = ["checked_locations", "split_locations"]


def _entry(loc, k, nodes):
    """One location, checked: a node name or a sorted-as-given pair of node names."""
    if isinstance(loc, str):
        if loc not in nodes:
            raise ValueError(f"locations[{k}]: {loc!r} is not a node of fe (fe.nodes)")
        return loc
    if isinstance(loc, tuple | list) and len(loc) == 2 and all(isinstance(n, str) for n in loc):
        a, b = loc
        for n in (a, b):
            if n not in nodes:
                raise ValueError(f"locations[{k}]: {n!r} in {tuple(loc)} is not a node of fe "
                                 "(fe.nodes)")
        xa, xb = (np.asarray(nodes[n], float) for n in (a, b))
        if a == b or not np.linalg.norm(xb - xa) > 0:
            raise ValueError(f"locations[{k}]: the pair {tuple(loc)} joins a node to itself "
                             "(or two nodes at the same place): it has no axis")
        return (a, b)
    raise TypeError(f"locations[{k}] must be a node name (str) or a pair of node names "
                    f"(tuple of two str), got {loc!r}")


def checked_locations(locations, fe, reach):
    """``locations`` as a tuple of node names and node-name pairs (duplicates dropped, the
    caller's order kept), or None; clear errors otherwise.  Nothing the caller passed is
    modified."""
    if locations is None:
        return None
    if fe is None or getattr(fe, "nodes", None) is None:
        raise ValueError("locations name nodes of the FE model: give fe (an FEModel with node "
                         "coordinates)")
    if reach is not None:
        raise ValueError("give either locations (the candidate locations themselves) or reach "
                         "(the default candidates' largest unconnected pair), not both")
    if isinstance(locations, str | bytes) or not hasattr(locations, "__iter__"):
        raise TypeError("locations must be a list of node names and pairs of node names, got "
                        f"{type(locations).__name__}")
    out, seen = [], set()
    for k, loc in enumerate(locations):
        entry = _entry(loc, k, fe.nodes)
        key = entry if isinstance(entry, str) else frozenset(entry)
        if key not in seen:
            seen.add(key)
            out.append(entry)
    if not out:
        raise ValueError("locations is empty: list at least one node or pair of nodes, or "
                         "leave it None for every element and node")
    return tuple(out)


def split_locations(fe, locations):
    """``(elements, other pairs, nodes)`` of a checked list: the pairs that are elements of
    ``fe`` first (the candidate groups count them apart), each list in the caller's order."""
    elements = {frozenset(e) for e in fe.elements or ()}
    elems, others, nodes = [], [], []
    for loc in locations:
        if isinstance(loc, str):
            nodes.append(loc)
        else:
            (elems if frozenset(loc) in elements else others).append(loc)
    return elems, others, nodes
