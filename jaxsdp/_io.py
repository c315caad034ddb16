"""Save and reload jaxsdp results: one `.npz` file, or JSON-ready plain Python.

`save(path, result)` / `load(path)` and `to_dict(result)` / `from_dict(d)`
work for every result object of jaxsdp (`DLRResult`, `SDPResult`,
`IDIMResult`, `EMPSStudy`, ...) and, generally, for any value built from:

- equinox Modules (or other dataclasses) and NamedTuples defined in jaxsdp
  (`jaxsdp.*` modules), recursively, static fields included;
- JAX arrays (reloaded as JAX arrays, weak type kept), NumPy arrays (reloaded
  as NumPy arrays) and NumPy scalars: dtype, shape and every bit kept
  (bool, integer, floating point incl. bfloat16, complex, and NumPy strings;
  JAX PRNG key arrays through their key data and implementation name);
- None, bool, int, float (non-finite ones too), complex, str, tuples, lists
  and dicts whose keys are str, int, float, bool or None (key types kept:
  an int key comes back an int).

**The format.** A JSON document (the *header*)::

    {"format": "jaxsdp-result", "format_version": 1, "jaxsdp_version": "0.1.0",
     "root": NODE}

where a NODE is a JSON null, boolean, integer, finite number or string (the
Python value itself), or an object tagged by `"type"`:

- `{"type": "float", "value": "nan" | "inf" | "-inf"}` (plus `"bits"`, the
  hexadecimal IEEE-754 bytes, little-endian, for a NaN other than NumPy's own);
- `{"type": "complex", "real": NODE, "imag": NODE}`;
- `{"type": "tuple" | "list", "items": [NODE, ...]}`;
- `{"type": "dict", "items": [[KEY_NODE, NODE], ...]}`;
- `{"type": "module", "module": ..., "qualname": ..., "fields": {name: NODE},
  "static": [names of the static fields]}` (a dataclass / equinox Module) or
  `{"type": "namedtuple", "module": ..., "qualname": ..., "fields": {...}}`;
- `{"type": "array", "kind": "jax" | "numpy", "dtype": "float64", "shape":
  [...], "weak_type": true (JAX, only when set)}` with either `"data"` (nested
  lists, as `to_dict` writes them; complex elements as `[real, imag]`,
  non-finite floats as the `"float"` objects above, flagged by
  `"nonfinite": true`) or `"key"` (the name of the `.npz` entry holding it, as
  `save` writes them);
- `{"type": "numpy_scalar", "dtype": ..., "value": NODE}`;
- `{"type": "prng_key", "impl": "threefry2x32", "key_data": ARRAY_NODE}`.

`to_dict` returns that document as plain Python (`json.dumps(d,
allow_nan=False)` works; finite floats round-trip exactly through their
`repr`). `save` writes a `.npz` archive: the header as a 0-d string entry
`__jaxsdp__`, and every array as its own entry under a path-like key
(`"idim/theta"`, `"sdp/result/par"`, ...; an array object met twice is
stored once). It is read back with `numpy.load(path, allow_pickle=False)`.

**Safety.** Loading never unpickles and never imports arbitrary code: a class
is rebuilt only when its module starts with one of `TRUSTED_PREFIXES`
(`"jaxsdp."`), it is defined there under the recorded name, and it is a
dataclass (equinox Module) or NamedTuple. It is rebuilt without running its
`__init__` (as equinox's own unflattening does: `object.__new__` then one
`object.__setattr__` per field), so `__post_init__` / `__check_init__` do not
run again. A file that is not a jaxsdp result, a newer format version, an
unknown or untrusted class, or a class whose fields have changed since the
file was written raises `ValueError` saying which.
"""

import dataclasses
import importlib
import json
import os
import re
import struct
import zipfile

import jax
import jax.numpy as jnp
import numpy as np

from ._runtime import x64
from ._version import __version__

FORMAT = "jaxsdp-result"
FORMAT_VERSION = 1
HEADER_KEY = "__jaxsdp__"
#: Classes are rebuilt only from modules whose name starts with one of these.
TRUSTED_PREFIXES = ("jaxsdp.",)
# Entry names np.savez cannot take as keywords, and the header's.
_RESERVED = {HEADER_KEY, "file", "args", "kwds", "allow_pickle"}
_NAN_BITS = struct.pack("<d", float("nan"))
_NONFINITE = {"nan": float("nan"), "inf": float("inf"), "-inf": float("-inf")}


def _where(path) -> str:
    return "/".join(path) if path else "the result"


def _is_namedtuple(cls) -> bool:
    return isinstance(cls, type) and issubclass(cls, tuple) and hasattr(cls, "_fields")


def _class_name(module, qualname) -> str:
    return f"{module}.{qualname}"


def _check_class_name(module, qualname):
    """ValueError unless `module.qualname` may be rebuilt (a jaxsdp dataclass/Module or NamedTuple)."""
    if not isinstance(module, str) or not isinstance(qualname, str):
        raise ValueError(f"invalid class name {module!r}.{qualname!r} in the file")
    full = _class_name(module, qualname)
    if not module.startswith(TRUSTED_PREFIXES):
        raise ValueError(
            f"class {full!r} is not a jaxsdp class: only classes from modules starting with "
            f"{' or '.join(TRUSTED_PREFIXES)} are saved and rebuilt"
        )
    parts = module.split(".") + qualname.split(".")
    if not all(p.isidentifier() and not p.startswith("__") for p in parts):
        raise ValueError(f"class {full!r} cannot be saved or rebuilt (a local or private-dunder name)")


def _float(v: float):
    if v - v == 0.0:  # finite
        return v
    if v == v:
        return {"type": "float", "value": "inf" if v > 0 else "-inf"}
    node = {"type": "float", "value": "nan"}
    bits = struct.pack("<d", v)
    if bits != _NAN_BITS:
        node["bits"] = bits.hex()
    return node


def _unfloat(node, path) -> float:
    if node.get("bits") is not None:
        try:
            return struct.unpack("<d", bytes.fromhex(node["bits"]))[0]
        except (TypeError, ValueError, struct.error):
            raise ValueError(f"{_where(path)}: invalid NaN bits {node['bits']!r}") from None
    try:
        return _NONFINITE[node["value"]]
    except (KeyError, TypeError):
        raise ValueError(f"{_where(path)}: invalid float {node.get('value')!r}") from None


def _mark(data):
    """Nested lists of Python floats with the non-finite ones as `{"type": "float", ...}`."""
    if isinstance(data, list):
        return [_mark(v) for v in data]
    return _float(data)


def _unmark(data, path):
    if isinstance(data, list):
        return [_unmark(v, path) for v in data]
    if isinstance(data, dict):
        return _unfloat(data, path)
    return data


def _is_floating(dtype) -> bool:
    return bool(jnp.issubdtype(dtype, jnp.floating))


def _dtype_name(dtype, path) -> str:
    dtype = np.dtype(dtype)
    if dtype.kind == "U":
        return dtype.str  # "<U5": the length is part of the dtype
    if dtype.kind in "biufc" or _is_floating(dtype):
        return dtype.name
    raise ValueError(
        f"{_where(path)}: arrays of dtype {dtype} cannot be saved "
        "(bool, integer, floating, complex and str arrays can; object arrays would need pickle)"
    )


def _resolve_dtype(name, path):
    try:
        if not isinstance(name, str):
            raise TypeError
        try:
            return np.dtype(name)
        except TypeError:
            return np.dtype(jnp.dtype(name))  # bfloat16, float8_*, ... (ml_dtypes)
    except (TypeError, ValueError, AttributeError):
        raise ValueError(f"{_where(path)}: unknown dtype {name!r}") from None


def _inline_data(a: np.ndarray, path):
    """(nested lists, whether they hold non-finite markers) for `to_dict`."""
    if a.dtype.kind in "biuU":
        return a.tolist(), False
    if a.dtype.itemsize > (16 if a.dtype.kind == "c" else 8):
        raise ValueError(f"{_where(path)}: {a.dtype} arrays have no exact plain-Python form; use `save`")
    if a.dtype.kind == "c":
        a = np.stack([a.real, a.imag], axis=-1)
    f = a.astype(np.float64)  # exact: every float of at most 64 bits is a float64
    if np.isfinite(f).all():
        return f.tolist(), False
    return _mark(f.tolist()), True


def _array_from_data(node, dtype, shape, path) -> np.ndarray:
    data = node["data"]
    if node.get("nonfinite"):
        data = _unmark(data, path)
    try:
        if dtype.kind == "c":
            pairs = np.asarray(data, dtype=np.float64).reshape(shape + (2,))
            a = np.empty(shape, dtype=dtype)
            a.real, a.imag = pairs[..., 0], pairs[..., 1]
            return a
        if _is_floating(dtype):
            return np.asarray(data, dtype=np.float64).reshape(shape).astype(dtype)
        return np.asarray(data, dtype=dtype).reshape(shape)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{_where(path)}: array data do not match dtype {dtype} and shape {shape}: {e}") from None


def _to_jax(a: np.ndarray, weak: bool, path):
    if a.dtype.kind == "U":
        raise ValueError(f"{_where(path)}: a JAX array cannot hold strings")
    with jax.enable_x64(True):  # keep float64/int64 whatever the caller's setting
        x = jnp.asarray(a)
        if weak:
            try:  # no public API makes a weakly typed array from data
                from jax._src.lax.lax import _convert_element_type

                x = _convert_element_type(x, x.dtype, weak_type=True)
            except (ImportError, AttributeError, TypeError):  # pragma: no cover - a later JAX
                pass
    return x


class _Encoder:
    """Python value -> header node; arrays inline (`to_dict`) or collected for the `.npz` (`save`)."""

    def __init__(self, inline: bool):
        self.inline = inline
        self.arrays: dict[str, np.ndarray] = {}
        self._stored: dict[int, tuple[object, str]] = {}  # id -> (array, key): store each array once

    def node(self, x, path=()):
        t = type(x)
        if x is None or t in (bool, int, str):
            return x
        if t is float:
            return _float(x)
        if t is complex:
            return {"type": "complex", "real": _float(x.real), "imag": _float(x.imag)}
        if isinstance(x, jax.core.Tracer):
            raise ValueError(f"{_where(path)}: a traced value; save results outside jit/vmap/grad")
        if isinstance(x, jax.Array):
            if jnp.issubdtype(x.dtype, jax.dtypes.prng_key):
                impl = str(jax.random.key_impl(x))
                return {"type": "prng_key", "impl": impl, "key_data": self.node(jax.random.key_data(x), path)}
            return self.array(x, "jax", path)
        if t is np.ndarray:
            return self.array(x, "numpy", path)
        if isinstance(x, np.generic):
            a = np.asarray(x)
            dtype = _dtype_name(a.dtype, path)  # first: refuses bytes, datetimes, objects
            return {"type": "numpy_scalar", "dtype": dtype, "value": _inline_data(a, path)[0]}
        if _is_namedtuple(t):
            return self.record(x, "namedtuple", t._fields, path)
        if t in (tuple, list):
            return {"type": t.__name__, "items": [self.node(v, path + (str(i),)) for i, v in enumerate(x)]}
        if t is dict:
            return {
                "type": "dict",
                "items": [[self.key(k, path), self.node(v, path + (str(k),))] for k, v in x.items()],
            }
        if dataclasses.is_dataclass(x) and not isinstance(x, type):
            return self.record(x, "module", [f.name for f in dataclasses.fields(x)], path)
        raise ValueError(
            f"{_where(path)}: cannot save a {t.__module__}.{t.__qualname__} (supported: jaxsdp Modules and "
            "NamedTuples, arrays, numbers, str, None, tuples, lists, dicts)"
        )

    def key(self, k, path):
        if k is None or type(k) in (bool, int, str, float):
            return self.node(k, path)
        raise ValueError(
            f"{_where(path)}: dict key {k!r} of type {type(k).__name__} (keys: str, int, float, bool, None)"
        )

    def record(self, x, kind, names, path):
        cls = type(x)
        try:
            _check_class_name(cls.__module__, cls.__qualname__)
        except ValueError as e:
            raise ValueError(f"{_where(path)}: {e}") from None
        node = {"type": kind, "module": cls.__module__, "qualname": cls.__qualname__}
        node["fields"] = {n: self.node(getattr(x, n), path + (n,)) for n in names}
        if kind == "module":
            node["static"] = [f.name for f in dataclasses.fields(x) if f.metadata.get("static", False)]
        return node

    def array(self, x, kind, path):
        a = np.asarray(x)
        node = {"type": "array", "kind": kind, "dtype": _dtype_name(a.dtype, path), "shape": list(a.shape)}
        if kind == "jax" and x.weak_type:
            node["weak_type"] = True
        if self.inline:
            node["data"], nonfinite = _inline_data(a, path)
            if nonfinite:
                node["nonfinite"] = True
            return node
        stored = self._stored.get(id(x))
        if stored is not None and stored[0] is x:
            node["key"] = stored[1]
            return node
        base = "/".join(re.sub(r"[^A-Za-z0-9_.+-]", "_", p) or "_" for p in path) or "root"
        key, n = base, 1
        while key in self.arrays or key in _RESERVED:
            key, n = f"{base}~{n}", n + 1
        self.arrays[key] = a
        self._stored[id(x)] = (x, key)
        node["key"] = key
        return node


def _resolve_class(module, qualname, kind, path):
    _check_class_name(module, qualname)
    full = _class_name(module, qualname)
    try:
        obj = importlib.import_module(module)
    except ImportError:
        raise ValueError(f"{_where(path)}: unknown class {full!r}: its module does not exist in this jaxsdp") from None
    for part in qualname.split("."):
        obj = getattr(obj, part, None)
    if not isinstance(obj, type) or obj.__module__ != module or obj.__qualname__ != qualname:
        raise ValueError(f"{_where(path)}: unknown class {full!r}: this jaxsdp ({__version__}) does not define it")
    if kind == "module" and not dataclasses.is_dataclass(obj) or kind == "namedtuple" and not _is_namedtuple(obj):
        raise ValueError(f"{_where(path)}: class {full!r} is not a {kind}")
    return obj


class _Decoder:
    """Header node -> Python value; arrays from the node (`from_dict`) or from the `.npz` (`load`)."""

    def __init__(self, npz=None):
        self.npz = npz
        self._loaded: dict[tuple, object] = {}

    def node(self, n, path=()):
        if n is None or type(n) in (bool, int, float, str):
            return n
        if not isinstance(n, dict):
            raise ValueError(f"{_where(path)}: invalid node {n!r:.80}")
        t = n.get("type")
        try:
            if t == "float":
                return _unfloat(n, path)
            if t == "complex":
                return complex(self.node(n["real"], path), self.node(n["imag"], path))
            if t in ("tuple", "list"):
                items = [self.node(v, path + (str(i),)) for i, v in enumerate(n["items"])]
                return tuple(items) if t == "tuple" else items
            if t == "dict":
                return {self.node(k, path): self.node(v, path + (str(k),)) for k, v in n["items"]}
            if t in ("module", "namedtuple"):
                return self.record(n, t, path)
            if t == "array":
                return self.array(n, path)
            if t == "numpy_scalar":
                dtype = _resolve_dtype(n["dtype"], path)
                return _array_from_data({"data": n["value"], "nonfinite": True}, dtype, (), path)[()]
            if t == "prng_key":
                data = self.node(n["key_data"], path)
                with jax.enable_x64(True):
                    return jax.random.wrap_key_data(data, impl=n["impl"])
        except (KeyError, TypeError) as e:
            raise ValueError(f"{_where(path)}: malformed {t!r} node ({type(e).__name__}: {e})") from None
        raise ValueError(f"{_where(path)}: unknown node type {t!r}")

    def record(self, n, kind, path):
        cls = _resolve_class(n["module"], n["qualname"], kind, path)
        saved = n["fields"]
        if not isinstance(saved, dict):
            raise TypeError("fields must be an object")
        names = [f.name for f in dataclasses.fields(cls)] if kind == "module" else list(cls._fields)
        missing = [f for f in names if f not in saved]
        extra = [f for f in saved if f not in names]
        if missing or extra:
            raise ValueError(
                f"{_where(path)}: class {_class_name(cls.__module__, cls.__qualname__)} has changed since the "
                f"file was written: fields missing from the file: {missing or 'none'}; fields in the file "
                f"that the class no longer has: {extra or 'none'}"
            )
        values = {f: self.node(saved[f], path + (f,)) for f in names}
        if kind == "namedtuple":
            return tuple.__new__(cls, [values[f] for f in names])
        obj = object.__new__(cls)  # as equinox's unflatten: no __init__, no __check_init__
        for f in names:
            object.__setattr__(obj, f, values[f])
        return obj

    def array(self, n, path):
        kind, dtype = n["kind"], _resolve_dtype(n["dtype"], path)
        shape = tuple(n["shape"])
        if kind not in ("jax", "numpy") or not all(type(s) is int and s >= 0 for s in shape):
            raise ValueError(f"{_where(path)}: invalid array kind {kind!r} or shape {shape}")
        weak = bool(n.get("weak_type", False))
        if "data" in n:
            a = _array_from_data(n, dtype, shape, path)
            return _to_jax(a, weak, path) if kind == "jax" else a
        key = n["key"]
        if self.npz is None:
            raise ValueError(f"{_where(path)}: the array is stored in an .npz entry {key!r}; read the file with `load`")
        cache = (key, kind, weak)
        if cache not in self._loaded:
            if key not in self.npz.files:
                raise ValueError(f"{_where(path)}: the file has no array entry {key!r}")
            a = self.npz[key]
            if a.dtype != dtype and a.dtype.kind == "V" and a.dtype.itemsize == dtype.itemsize:
                a = a.view(dtype)  # ml_dtypes (bfloat16, ...) are stored as raw bytes
            if a.dtype != dtype or a.shape != shape:
                raise ValueError(
                    f"{_where(path)}: entry {key!r} holds {a.dtype} {a.shape}, the header says {dtype} {shape}"
                )
            self._loaded[cache] = _to_jax(a, weak, path) if kind == "jax" else a
        return self._loaded[cache]


def _header(root) -> dict:
    return {"format": FORMAT, "format_version": FORMAT_VERSION, "jaxsdp_version": __version__, "root": root}


def _check_header(d, what):
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise ValueError(f"{what} is not a jaxsdp result (no {{'format': {FORMAT!r}}} header)")
    version = d.get("format_version")
    if type(version) is not int or "root" not in d:
        raise ValueError(f"{what} is not a jaxsdp result (no format version or no root)")
    if version > FORMAT_VERSION:
        raise ValueError(
            f"{what} has format version {version} (written by jaxsdp {d.get('jaxsdp_version')}); this jaxsdp "
            f"({__version__}) reads format versions up to {FORMAT_VERSION}: upgrade jaxsdp"
        )


@x64
def to_dict(result) -> dict:
    """A jaxsdp result as JSON-ready plain Python (dicts, lists, str, numbers, bools, None).

    Saves the class (module and qualified name) and every field, static or
    not, recursively; arrays as nested lists with their kind (JAX or NumPy),
    dtype and shape; non-finite floats as `{"type": "float", "value": "nan"}`
    (or `"inf"`, `"-inf"`), so `json.dumps(d, allow_nan=False)` works.
    Format: `{"format": "jaxsdp-result", "format_version", "jaxsdp_version",
    "root"}`; each node is a plain value or an object with a `"type"`
    (`module`, `namedtuple`, `array`, `tuple`, `list`, `dict` as key-value
    pairs so int keys stay int, `float` for non-finite values). `from_dict`
    rebuilds the result exactly (every bit of every array).

    Example:
        >>> import json, numpy as np, jaxsdp
        >>> from jaxsdp import from_dict, to_dict
        >>> X = np.column_stack([np.ones(8), np.arange(8.0)])
        >>> res = jaxsdp.idim_ls(X @ np.array([1.0, 2.0]) + np.sin(np.arange(8.0)), X, names=("a", "b"))
        >>> text = json.dumps(to_dict(res), allow_nan=False)
        >>> back = from_dict(json.loads(text))
        >>> back.names, bool((back.theta == res.theta).all())
        (('a', 'b'), True)
    """
    return _header(_Encoder(inline=True).node(result))


@x64
def from_dict(d: dict):
    """Rebuild a result from `to_dict`'s output (or its JSON round trip).

    Safety: nothing is imported beyond jaxsdp; the classes rebuilt are
    only those defined in a `jaxsdp.` module under the saved module and
    qualified name that are dataclasses/equinox Modules or NamedTuples, filled
    field by field without running their `__init__`. Raises `ValueError` for a dict that is not a
    jaxsdp result, a newer format version, an unknown class (named) or a class
    whose fields changed since (the missing and extra fields listed).

    Example:
        >>> import numpy as np
        >>> from jaxsdp import from_dict, to_dict
        >>> from_dict(to_dict({"nvr": np.array([1e-3, np.inf]), 10: ("a", None)}))
        {'nvr': array([0.001,   inf]), 10: ('a', None)}
    """
    _check_header(d, "the dict")
    return _Decoder().node(d["root"])


@x64
def save(path, result, *, compress: bool = False) -> None:
    """Write a jaxsdp result to one `.npz` file at `path` (a path, written as given, or a binary file).

    Every array is an entry of the archive under a path-like key (the field
    path: `"sdp/result/par"`), and the rest (classes, fields, static fields,
    numbers, strings, containers, array kinds, dtypes and shapes, the format
    version and the jaxsdp version) is one JSON string entry, `__jaxsdp__`,
    in the format of `to_dict` with arrays referenced by key. `compress=True`
    deflates the entries. Only jaxsdp results (and plain containers, numbers,
    strings and arrays) can be saved: anything else is a `ValueError` before
    the file is written.
    Reload with `load`; `numpy.load(path, allow_pickle=False)` also reads it.

    Example:
        >>> import io, numpy as np, jaxsdp
        >>> from jaxsdp import load, save
        >>> X = np.column_stack([np.ones(8), np.arange(8.0)])
        >>> res = jaxsdp.idim_ls(X @ np.array([1.0, 2.0]) + np.sin(np.arange(8.0)), X, names=("a", "b"))
        >>> buffer = io.BytesIO()
        >>> save(buffer, res)
        >>> _ = buffer.seek(0)
        >>> back = load(buffer)
        >>> type(back).__name__, back.names, float(back["b"]) == float(res["b"])
        ('IDIMResult', ('a', 'b'), True)
    """
    encoder = _Encoder(inline=False)
    header = json.dumps(_header(encoder.node(result)), allow_nan=False)
    entries = {HEADER_KEY: np.array(header), **encoder.arrays}
    write = np.savez_compressed if compress else np.savez
    if isinstance(path, (str, os.PathLike)):
        with open(path, "wb") as f:
            write(f, **entries)
    else:
        write(path, **entries)


@x64
def load(path):
    """Read a result written by `save` (a path or a binary file).

    Arrays come back with their dtype, shape and kind (JAX or NumPy), classes
    as they were saved. Safety: nothing is unpickled (`allow_pickle=False`)
    and nothing is imported beyond jaxsdp; only classes defined in a `jaxsdp.`
    module under the saved name that are dataclasses/equinox Modules or
    NamedTuples are rebuilt, field by field, without running their `__init__`.
    Raises `ValueError` for a file that is not a jaxsdp result, a newer format
    version, an unknown class (named) or a class whose fields changed since the
    file was written (the missing and extra fields listed).

    Example:
        >>> import io, numpy as np
        >>> from jaxsdp import load, save
        >>> buffer = io.BytesIO()
        >>> save(buffer, {"nvr": np.array([1e-3, 1e-5]), "model": "IRW"})
        >>> _ = buffer.seek(0)
        >>> load(buffer)["model"]
        'IRW'
    """
    what = repr(os.fspath(path)) if isinstance(path, (str, os.PathLike)) else "the file"
    try:
        archive = np.load(path, allow_pickle=False)
    except (ValueError, EOFError, zipfile.BadZipFile) as e:
        raise ValueError(f"{what} is not a jaxsdp result file (not a readable .npz archive: {e})") from None
    if not isinstance(archive, np.lib.npyio.NpzFile):
        raise ValueError(f"{what} is not a jaxsdp result file (a single .npy array, not an .npz archive)")
    with archive:
        if HEADER_KEY not in archive.files:
            raise ValueError(f"{what} is not a jaxsdp result file (an .npz without the {HEADER_KEY!r} header entry)")
        text = archive[HEADER_KEY]
        try:
            header = json.loads(str(text[()])) if text.dtype.kind == "U" and text.shape == () else None
        except json.JSONDecodeError:
            header = None
        _check_header(header, what)
        return _Decoder(archive).node(header["root"])
