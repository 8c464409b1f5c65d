"""safetensors files as momu writes and reads them: deterministic bytes, checked headers.

* :func:`write_safetensors` / :func:`save_module` write the same bytes for the same tensors and
  metadata (safetensors' own writer orders metadata keys by hash, so identical runs gave
  byte-different files), atomically, with the permissions a plain ``open()`` gives (its writer
  creates files ``0600``).
* :func:`read_header` reads only the JSON header — names, dtypes, shapes — checking it against
  the file's size, so a caller can compare shapes with what it is about to build *before*
  allocating anything.
* :func:`check_tensors` refuses integer tensors where floating ones are expected and any NaN or
  infinite weight.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch

from momu.io import atomic_write_bytes

__all__ = [
    "write_safetensors",
    "save_module",
    "read_header",
    "TensorInfo",
    "check_tensors",
    "MAX_HEADER_BYTES",
]

MAX_HEADER_BYTES = 100 * 1024 * 1024
"""The largest safetensors header read (safetensors' own limit)."""

_DTYPE_SIZES = {
    "BOOL": 1,
    "U8": 1,
    "I8": 1,
    "F8_E5M2": 1,
    "F8_E4M3": 1,
    "I16": 2,
    "U16": 2,
    "F16": 2,
    "BF16": 2,
    "I32": 4,
    "U32": 4,
    "F32": 4,
    "I64": 8,
    "U64": 8,
    "F64": 8,
}
_TORCH_NAMES = {
    torch.bool: "BOOL",
    torch.uint8: "U8",
    torch.int8: "I8",
    torch.int16: "I16",
    torch.float16: "F16",
    torch.bfloat16: "BF16",
    torch.int32: "I32",
    torch.float32: "F32",
    torch.int64: "I64",
    torch.float64: "F64",
}
TensorInfo = tuple[str, tuple[int, ...]]
"""``(safetensors dtype name, shape)`` of one stored tensor."""


def _deterministic(data: bytes, metadata: Mapping[str, str] | None) -> bytes:
    """``data`` (a safetensors file without metadata) with ``metadata`` added, keys sorted."""
    (length,) = struct.unpack("<Q", data[:8])
    header = json.loads(data[8 : 8 + length])
    body = data[8 + length :]
    ordered: dict[str, Any] = {}
    if metadata:
        ordered["__metadata__"] = {str(k): str(v) for k, v in sorted(metadata.items())}
    ordered.update(header)
    text = json.dumps(ordered, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 8)  # the data stays 8-byte aligned, as safetensors writes it
    return struct.pack("<Q", len(text)) + text + body


def write_safetensors(
    path: str | Path, tensors: Mapping[str, torch.Tensor], metadata: Mapping[str, str] | None = None
) -> Path:
    """Write ``tensors`` (and string ``metadata``) to ``path``: same input, same bytes; atomic."""
    from safetensors.torch import save

    plain = {k: v.detach().cpu().contiguous() for k, v in tensors.items()}
    return atomic_write_bytes(path, _deterministic(save(plain), metadata))


def save_module(module: torch.nn.Module, path: str | Path, metadata: Mapping[str, str] | None = None) -> Path:
    """``safetensors.torch.save_model`` with deterministic bytes: tied tensors stored once.

    A tensor sharing storage with another is dropped and recorded in the metadata as
    ``alias -> kept name`` (what ``save_model`` does), so loading with ``strict=False`` and
    re-tying works as with safetensors' own files.
    """
    from safetensors.torch import _remove_duplicate_names

    state = module.state_dict()
    meta = dict(metadata or {})
    for kept, removed in _remove_duplicate_names(state).items():
        for name in removed:
            meta.setdefault(name, kept)
            del state[name]
    return write_safetensors(path, state, meta)


def read_header(path: str | Path) -> tuple[dict[str, TensorInfo], dict[str, str]]:
    """``({name: (dtype, shape)}, metadata)`` from a safetensors header, checked against the file size.

    Raises:
        ValueError: not a safetensors file, a header that does not parse, unknown dtypes, or data
            offsets that do not match the shapes or the file (the message names the file).
    """
    path = Path(path)
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(8)
        if len(head) < 8:
            raise ValueError(f"{path}: not a safetensors file (shorter than its 8-byte header length)")
        (length,) = struct.unpack("<Q", head)
        if length > min(MAX_HEADER_BYTES, size - 8):
            raise ValueError(
                f"{path}: not a safetensors file (header length {length} for a {size}-byte file)"
            )
        try:
            header = json.loads(fh.read(length))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ValueError(f"{path}: not a safetensors file (header is not JSON: {exc})") from None
    if not isinstance(header, dict):
        raise ValueError(f"{path}: not a safetensors file (header is not a JSON object)")
    metadata = header.pop("__metadata__", None) or {}
    data_size = size - 8 - length
    infos: dict[str, TensorInfo] = {}
    for name, entry in header.items():
        try:
            dtype, shape, (start, end) = (
                entry["dtype"],
                tuple(int(n) for n in entry["shape"]),
                entry["data_offsets"],
            )
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"{path}: tensor {name!r} has a malformed header entry") from None
        if dtype not in _DTYPE_SIZES:
            raise ValueError(f"{path}: tensor {name!r} has unknown dtype {dtype!r}")
        count = 1
        for n in shape:
            count *= n
        if (
            any(n < 0 for n in shape)
            or not 0 <= start <= end <= data_size
            or end - start != count * _DTYPE_SIZES[dtype]
        ):
            raise ValueError(
                f"{path}: tensor {name!r} {dtype}{list(shape)} does not match its data offsets "
                f"[{start}, {end}) in {data_size} bytes of data (truncated or corrupt)"
            )
        infos[str(name)] = (dtype, shape)
    return infos, {str(k): str(v) for k, v in metadata.items()}


def dtype_name(dtype: torch.dtype) -> str:
    """The safetensors name of a torch dtype (``torch.float32 -> "F32"``)."""
    return _TORCH_NAMES.get(dtype, str(dtype))


def check_tensors(path: str | Path, tensors: Mapping[str, torch.Tensor]) -> None:
    """Refuse NaN or infinite values in floating tensors.

    Raises:
        ValueError: naming the file and the first tensors with non-finite values.
    """
    bad = [
        name
        for name, t in tensors.items()
        if t.is_floating_point() and t.numel() and not bool(torch.isfinite(t).all())
    ]
    if bad:
        more = " …" if len(bad) > 5 else ""
        raise ValueError(f"{path}: NaN or infinite weights in {', '.join(bad[:5])}{more}")
