"""ecmor from Python: error-controlled model order reduction of large sparse models.

    import ecmor
    model = ecmor.SecondOrder(M, D, K, B, C)          # NumPy arrays or any scipy.sparse format
    result = ecmor.reduce(model, band=(1.0, 500.0), tol=1e-3)
    result.order, result.rom.K, result.V, result.history, result.summary

The run is the CLI's own (`ecmor reduce`): the same reducers, strategies, option checks and
messages. See docs/python.md.
"""
import difflib
import json
import os
import signal
import threading
import warnings as _warnings

# Idle OpenMP threads sleep instead of spinning, as in the `ecmor` executable (docs/user-guide.md,
# "Threads"). OpenMP reads this when it starts: it has effect only when neither NumPy nor anything
# else has loaded the OpenMP runtime yet, i.e. when ecmor is imported first. A user's setting wins.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numpy as np  # noqa: E402  (after the wait policy, see above)

from . import _ecmor
from ._paths import PLUGIN_DIR_FROM_PACKAGE

__all__ = [
    "Error", "Interrupted", "SecondOrder", "Descriptor", "ReducedModel", "Result", "load",
    "reduce", "frequency_response", "band_error", "plugins", "strategies", "export_body",
]
__version__ = _ecmor.version

#: Every error ecmor reports: bad input (a matrix, a configuration key, an option), a plugin that
#: cannot be loaded, a numerical failure. A ValueError; its text is the CLI's.
Error = _ecmor.Error


class Interrupted(KeyboardInterrupt):
    """Ctrl-C (SIGINT) stopped ecmor.reduce at its next safe point. `result` is the partial
    Result: the history so far and the best model found, if any (as the CLI keeps them)."""

    def __init__(self, message, result):
        super().__init__(message)
        self.result = result


def _plugin_dirs():
    """$ECMOR_PLUGIN_PATH, then the bundled plugins beside this package (build or install tree)."""
    dirs = [d for d in os.environ.get("ECMOR_PLUGIN_PATH", "").split(os.pathsep) if d]
    here = os.path.dirname(os.path.abspath(__file__))
    dirs.append(os.path.normpath(os.path.join(here, PLUGIN_DIR_FROM_PACKAGE)))
    return dirs


# ---- matrices in --------------------------------------------------------------------------------

def _is_sparse(a):
    try:
        import scipy.sparse
    except ImportError:
        return False
    return scipy.sparse.issparse(a)


def _input(name, a):
    """The tuple the C++ side reads (python/src/arrays.hpp). csc, csr and coo arrays are read in
    place; other sparse formats are converted to COO first (one temporary copy)."""
    if a is None:
        raise Error(f"{name}: missing (None): a NumPy array or a scipy.sparse matrix is required")
    if _is_sparse(a):
        if a.format not in ("csc", "csr", "coo"):
            a = a.tocoo()
        if a.format == "coo":
            return ("coo", name, tuple(a.shape), a.row, a.col, a.data)
        return (a.format, name, tuple(a.shape), a.indptr, a.indices, a.data)
    if not isinstance(a, np.ndarray):
        try:
            a = np.asarray(a)
        except Exception as e:  # ragged lists and the like
            raise Error(f"{name}: not readable as a matrix ({e})") from None
    return ("dense", name, a)


def _csc(view):
    """A scipy CSC matrix on ecmor's own storage (read-only, no copy)."""
    import scipy.sparse
    (data, indices, indptr), shape = view[1], view[2]
    m = scipy.sparse.csc_matrix((data, indices, indptr), shape=shape, copy=False)
    m.has_canonical_format = True  # sorted, no duplicates: scipy must not sort read-only arrays
    return m


class _FullModel:
    """Shared part of SecondOrder and Descriptor: a full sparse model held by ecmor."""

    _names = ()

    @classmethod
    def _wrap(cls, cpp):
        obj = cls.__new__(SecondOrder if cpp.kind == "second order" else Descriptor)
        obj._cpp = cpp
        return obj

    def _matrix(self, name):
        view = self._cpp.matrix(name)
        if view is None:
            return None
        return _csc(view) if view[0] == "sparse" else view[1]

    @property
    def kind(self):
        """'second order' or 'descriptor'."""
        return self._cpp.kind

    @property
    def N(self):
        """Number of degrees of freedom (second order) or states (descriptor)."""
        return self._cpp.N

    @property
    def inputs(self):
        return self._cpp.inputs

    @property
    def outputs(self):
        return self._cpp.outputs

    @property
    def matrices(self):
        """The matrices by name: sparse (scipy CSC) or dense (NumPy), read-only views."""
        return {n: self._matrix(n) for n in self._names if self._matrix(n) is not None}

    def __repr__(self):
        return (f"<ecmor.{type(self).__name__}: N = {self.N}, {self.inputs} input(s), "
                f"{self.outputs} output(s)>")


class SecondOrder(_FullModel):
    """M q'' + D q' + K q = B u,  y = C q + Cv q'  (N degrees of freedom, m inputs, p outputs).

    M, D, K (N x N) and B (N x m), C, Cv (p x N): NumPy arrays or any scipy.sparse matrix; D=None
    means no damping, Cv=None no velocity output. Values must be real (float64, float32 or
    integers: nothing else is cast). ecmor keeps its own copy in compressed sparse columns: one
    copy of each matrix, read straight from csc, csr, coo or dense input (other sparse formats
    pass through COO first). The attributes M, D, K, B, C, Cv are read-only views of that copy.
    """

    _names = ("M", "D", "K", "B", "C", "Cv")

    def __init__(self, M, D, K, B, C, Cv=None):
        if D is None:
            import scipy.sparse
            D = scipy.sparse.csc_matrix(np.shape(K) if not _is_sparse(K) else K.shape)
        self._cpp = _ecmor.second_order(_input("M", M), _input("D", D), _input("K", K),
                                        _input("B", B), _input("C", C),
                                        None if Cv is None else _input("Cv", Cv),
                                        "ecmor.SecondOrder")

    M = property(lambda self: self._matrix("M"), doc="mass, N x N (scipy CSC, read-only)")
    D = property(lambda self: self._matrix("D"), doc="damping, N x N")
    K = property(lambda self: self._matrix("K"), doc="stiffness, N x N")
    B = property(lambda self: self._matrix("B"), doc="input, N x m (NumPy, read-only)")
    C = property(lambda self: self._matrix("C"), doc="position output, p x N")
    Cv = property(lambda self: self._matrix("Cv"), doc="velocity output, p x N, or None")


class Descriptor(_FullModel):
    """E x' = A x + B u,  y = C x  (E may be singular: a DAE). Arguments as for SecondOrder."""

    _names = ("E", "A", "B", "C")

    def __init__(self, E, A, B, C):
        self._cpp = _ecmor.descriptor(_input("E", E), _input("A", A), _input("B", B),
                                      _input("C", C), "ecmor.Descriptor")

    E = property(lambda self: self._matrix("E"), doc="descriptor matrix, N x N")
    A = property(lambda self: self._matrix("A"), doc="system matrix, N x N")
    B = property(lambda self: self._matrix("B"), doc="input, N x m")
    C = property(lambda self: self._matrix("C"), doc="output, p x N")


class ReducedModel:
    """A reduced (dense) model: second order (M, D, K, B, C, Cv) or descriptor (E, A, B, C), its
    matrices as read-only NumPy arrays. Result.rom is one; ReducedModel.second_order(...) and
    ReducedModel.descriptor(...) make one from your own arrays (for band_error)."""

    def __init__(self, cpp):
        self._cpp = cpp

    @classmethod
    def second_order(cls, M, D, K, B, C, Cv=None):
        return cls(_ecmor.reduced_second_order(
            _input("M", M), _input("D", D), _input("K", K), _input("B", B), _input("C", C),
            None if Cv is None else _input("Cv", Cv), "ecmor.ReducedModel"))

    @classmethod
    def descriptor(cls, E, A, B, C):
        return cls(_ecmor.reduced_descriptor(_input("E", E), _input("A", A), _input("B", B),
                                             _input("C", C), "ecmor.ReducedModel"))

    @property
    def kind(self):
        return self._cpp.kind

    @property
    def order(self):
        return self._cpp.order

    @property
    def matrices(self):
        names = ("M", "D", "K", "B", "C", "Cv") if self.kind == "second order" else (
            "E", "A", "B", "C")
        out = {n: self._cpp.matrix(n) for n in names}
        return {n: m for n, m in out.items() if m is not None}

    def __getattr__(self, name):
        if name in ("M", "D", "K", "B", "C", "Cv", "E", "A"):
            try:
                return self._cpp.matrix(name)
            except KeyError:
                raise AttributeError(f"a {self.kind} reduced model has no {name}") from None
        raise AttributeError(name)

    def __repr__(self):
        return f"<ecmor.ReducedModel: {self.kind}, order {self.order}>"


def load(path, variables=None):
    """A model directory of Matrix Market files (.mtx or .mtx.gz) or a MATLAB .mat file, as the
    CLI reads it; `variables` renames the .mat variables, e.g. {"M": "Mass"}."""
    return _FullModel._wrap(_ecmor.load(os.fspath(path), dict(variables or {})))


# ---- runs ---------------------------------------------------------------------------------------

class Result:
    """What ecmor.reduce returns: the reduced model, its bases, the history and the summary."""

    def __init__(self, run):
        self._run = run
        self.summary = json.loads(run.summary_json) if run.summary_json else {}
        self.history = [json.loads(line) for line in run.history]

    @property
    def rom(self):
        """The reduced model (ReducedModel), or None when the run produced none."""
        return ReducedModel(self._run.reduced()) if self._run.has_model else None

    @property
    def V(self):
        """Right basis, N x n (read-only view), or None."""
        return self._run.basis("V")

    @property
    def W(self):
        """Left basis, N x n (read-only view), or None."""
        return self._run.basis("W")

    order = property(lambda self: self.summary.get("final_order"))
    band_error = property(lambda self: self.summary.get("band_error"))
    target_met = property(lambda self: bool(self.summary.get("target_met")))
    termination = property(lambda self: self.summary.get("termination"))
    message = property(lambda self: self.summary.get("message"))

    def save(self, directory, format="mtx"):
        """Writes what `ecmor reduce` writes into `directory`: the reduced matrices, V and W
        (format mtx, mat or both), history.csv, history.jsonl, band_error.csv and summary.json."""
        self._run.save(os.fspath(directory), format)

    def __repr__(self):
        return (f"<ecmor.Result: {self.termination}, order {self.order}, band error "
                f"{self.band_error}>")


def _plain(x):
    """json.dumps' fallback for NumPy scalars and arrays and paths."""
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, os.PathLike):
        return os.fspath(x)
    raise TypeError(f"{type(x).__name__} is not a configuration value")


# The sections a loose keyword option may belong to besides the reducer's and strategy's: the
# others (model, band, target, output, check) have their own arguments or are given as dicts.
_LOOSE_SECTIONS = ("error", "solver", "backend")


def _route(options, reducer, strategy):
    """Assigns each loose keyword option to the section whose option specs name it."""
    if not options:
        return {}
    reducers, strategies, sections, _ = _ecmor.plugins(_plugin_dirs())
    owners = {}
    if reducer is not None:
        for r in reducers:
            if r["name"] == reducer:
                owners["reducer"] = {p["name"] for p in r["parameters"]}
    owners["strategy"] = {p["name"] for p in strategies.get(strategy, [])}
    for name, params in sections.items():
        names = {p["name"] for p in params}
        if name in ("reducer", "strategy"):  # the section's own keys (time_limit_s), not `name`
            owners[name] = owners.get(name, set()) | (names - {"name"})
        elif name in _LOOSE_SECTIONS:
            owners[name] = names
    routed = {}
    for key, value in options.items():
        where = [s for s, names in owners.items() if key in names]
        if len(where) > 1:
            raise Error(f"ecmor.reduce: option '{key}' is an option of {' and '.join(where)}: "
                        f"pass it inside {where[0]}={{...}} or {where[1]}={{...}}")
        if not where:
            known = sorted(set().union(*owners.values()))
            near = difflib.get_close_matches(key, known, n=1)
            hint = f" (did you mean '{near[0]}'?)" if near else ""
            raise Error(f"ecmor.reduce: unknown option '{key}'{hint}; the options of "
                        + "; ".join(f"{s}: {', '.join(sorted(n))}" for s, n in owners.items()
                                    if n))
        routed.setdefault(where[0], {})[key] = value
    return routed


def _keyword_config(band, tol, norm, reducer, strategy, options):
    if band is None:
        raise Error("ecmor.reduce: band = (f_min_hz, f_max_hz) is required")
    try:
        f_min, f_max = band
    except (TypeError, ValueError):
        raise Error(f"ecmor.reduce: band = {band!r}: must be a pair (f_min_hz, f_max_hz)") from None
    cfg = {"band": {"f_min_hz": f_min, "f_max_hz": f_max},
           "target": {"tolerance": 1e-3 if tol is None else tol}}
    if norm is not None:
        cfg["target"]["norm"] = norm
    sections = {k: options.pop(k) for k in list(options) if k in _ecmor.config_keys()}
    if "model" in sections:
        raise Error("ecmor.reduce: the model is the first argument; model= names none")
    strategy_section = dict(strategy) if isinstance(strategy, dict) else {
        "name": strategy or "greedy_points"}
    portfolio = strategy_section.get("name") == "portfolio"
    reducer_section = None
    if reducer is not None or not portfolio:
        reducer_section = dict(reducer) if isinstance(reducer, dict) else {
            "name": reducer or "krylov"}
    for section, values in _route(options, reducer_section and reducer_section.get("name"),
                                  strategy_section.get("name")).items():
        target = {"reducer": reducer_section, "strategy": strategy_section}.get(section)
        if target is None:
            target = sections.setdefault(section, {})
        target.update(values)
    cfg["strategy"] = strategy_section
    if reducer_section is not None:
        cfg["reducer"] = reducer_section
    cfg.update(sections)
    return cfg


def reduce(model=None, config=None, *, band=None, tol=None, norm=None, reducer=None,
           strategy=None, progress=None, **options):
    """Reduces a model to the smallest order whose relative band error meets the tolerance.

    Forms:
      reduce(model, band=(f_min_hz, f_max_hz), tol=1e-3, reducer="krylov",
             strategy="greedy_points", **options)
      reduce(model, config)        config: a dict of the YAML schema without `model`
      reduce(config)               config: a dict of the YAML schema with `model`
      reduce("run.yaml")           a YAML file, exactly as `ecmor reduce run.yaml`

    `options` go to the reducer, the strategy or the error/solver sections, whichever names
    them (reducer= and strategy= may also be dicts with their options). Sections may be given
    as dicts: error={...}, solver={...}, output={"dir": ...} (the CLI's files are then written
    there as the run goes). `progress` is called with each iteration's history row (a dict).
    Returns a Result. Raises ecmor.Error for bad input (the CLI's text) and ecmor.Interrupted
    (a KeyboardInterrupt carrying the partial Result) on Ctrl-C.
    """
    keywords = band is not None or tol is not None or norm is not None or reducer is not None \
        or strategy is not None or bool(options)
    from_file = False
    if isinstance(model, dict):
        if config is not None:
            raise Error("ecmor.reduce: give one configuration (a dict), not two")
        model, config = None, model
    elif isinstance(model, (str, os.PathLike)):
        if config is not None or keywords:
            raise Error("ecmor.reduce: a YAML file is the whole run: no config or keywords beside it")
        text, name, from_file = os.fspath(model), "", True
        model = None
    elif model is not None and not isinstance(model, _FullModel):
        raise Error(f"ecmor.reduce: the model is a {type(model).__name__}: expected "
                    "ecmor.SecondOrder, ecmor.Descriptor (or ecmor.load(path)), a config dict or "
                    "a YAML path")
    if not from_file:
        if config is not None:
            if keywords:
                raise Error("ecmor.reduce: give the run as a config dict or as keywords (band=, "
                            "tol=, ...), not both")
            if not isinstance(config, dict):
                raise Error(f"ecmor.reduce: config is a {type(config).__name__}: expected a dict")
            cfg, name = config, "config"
        else:
            if model is None:
                raise Error("ecmor.reduce: no model: pass ecmor.SecondOrder(...), "
                            "ecmor.Descriptor(...), ecmor.load(path) or a config dict")
            cfg, name = _keyword_config(band, tol, norm, reducer, strategy, dict(options)), \
                "ecmor.reduce"
        text = json.dumps(cfg, default=_plain)
    callback = None
    if progress is not None:
        if not callable(progress):
            raise Error(f"ecmor.reduce: progress is a {type(progress).__name__}: must be callable")

        def callback(line):
            progress(json.loads(line))
    catch = (threading.current_thread() is threading.main_thread()
             and signal.getsignal(signal.SIGINT) is signal.default_int_handler)
    run, signalled, callback_error, problems = _ecmor.reduce(
        text, name, from_file, None if model is None else model._cpp, callback, _plugin_dirs(),
        catch)
    for problem in problems:
        _warnings.warn(f"ecmor: {problem}", RuntimeWarning, stacklevel=2)
    result = Result(run)
    if callback_error is not None:
        try:
            callback_error.result = result
        except AttributeError:
            pass
        raise callback_error
    if signalled:
        raise Interrupted(f"ecmor.reduce stopped by Ctrl-C after {len(result.history)} "
                          "iteration(s); the partial result is the exception's .result", result)
    return result


# ---- the tools around a run ----------------------------------------------------------------------

def _reduced_of(rom):
    if isinstance(rom, Result):
        rom = rom.rom
        if rom is None:
            raise Error("the run produced no reduced model")
    if not isinstance(rom, ReducedModel):
        raise Error(f"expected an ecmor.ReducedModel or ecmor.Result, got {type(rom).__name__}")
    return rom


def frequency_response(model, f_hz, threads=0):
    """H(i 2 pi f) of a full model (SecondOrder, Descriptor), a ReducedModel or a Result's model,
    as a complex array of shape (len(f_hz), outputs, inputs), or (outputs, inputs) for one f."""
    f = np.asarray(f_hz, dtype=float)
    scalar = f.ndim == 0
    freqs = [float(x) for x in np.atleast_1d(f)]
    if isinstance(model, _FullModel):
        h = _ecmor.response_full(model._cpp, freqs, int(threads))
    else:
        h = _ecmor.response_reduced(_reduced_of(model)._cpp, freqs)
    return h[0] if scalar else h


def band_error(model, rom, band, norm="spectral", grid_points=200, threads=0):
    """The relative band error of `rom` against the full `model` (the seed's Eqs. 22/23: norm
    "spectral" or "frobenius"), every sample against the full model's own response: a log grid of
    grid_points, the reduced poles in the band and refinement of the peaks. Returns a dict:
    sup_relative, f_peak_hz, and the curves f_hz, relative, relative_spectral, ..."""
    if not isinstance(model, _FullModel):
        raise Error(f"band_error: the full model is a {type(model).__name__}: expected "
                    "ecmor.SecondOrder or ecmor.Descriptor")
    f_min, f_max = band
    return _ecmor.band_error(model._cpp, _reduced_of(rom)._cpp, float(f_min), float(f_max), norm,
                             int(grid_points), int(threads))


def plugins():
    """The reducers that ecmor.reduce can use (bundled and from $ECMOR_PLUGIN_PATH), each a dict:
    name, version, description, second_order, descriptor, library, parameters."""
    reducers, _, _, problems = _ecmor.plugins(_plugin_dirs())
    for problem in problems:
        _warnings.warn(f"ecmor: {problem}", RuntimeWarning, stacklevel=2)
    return reducers


def strategies():
    """The strategies and their options: {name: [parameter dicts]}."""
    return _ecmor.plugins(_plugin_dirs())[1]


def export_body(result, path, nodes, dofs, all_nodes=False, mass_model=None, name="ecmor"):
    """Writes the run's reduced elastic body for multibody simulation: the SID file at `path`
    and its .json and .mat companions (docs/multibody.md), as `ecmor export-body` does.

    nodes: k x 4 array (node id, x, y, z); dofs: N x 2 array (node id, direction: 1..3
    translations x, y, z, 4..6 rotations), row r for row r of M. The frame holds the nodes where B
    or C act (all_nodes=True: every node). mass_model=(M, nodes, dofs): the same mesh without
    boundary conditions, for the mass of constrained DOFs. A free-floating body's rigid-body
    motions move its frame (mean axes). Returns a dict: the files, mass, center, J, coordinates,
    free_motions, frame_nodes, check (W'MV, W'DV, W'KV against the run's), warnings."""
    if not isinstance(result, Result):
        raise Error(f"export_body: expected an ecmor.Result, got {type(result).__name__}")
    mass = None
    if mass_model is not None:
        try:
            M, mass_nodes, mass_dofs = mass_model
        except (TypeError, ValueError):
            raise Error("export_body: mass_model must be (M, nodes, dofs)") from None
        mass = (_input("M", M), _input("nodes", mass_nodes), _input("dofs", mass_dofs))
    out = _ecmor.export_body(result._run, os.fspath(path), _input("nodes", nodes),
                             _input("dofs", dofs), bool(all_nodes), mass, str(name))
    for w in out["warnings"]:
        _warnings.warn(f"ecmor: {w}", RuntimeWarning, stacklevel=2)
    return out
