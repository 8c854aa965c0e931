"""Decoding ``sensor_msgs/PointCloud2`` by each field's offset and datatype.

Written from the message definition (sensor_msgs/msg/PointCloud2.msg and PointField.msg, ROS 2
``common_interfaces``): a cloud is ``height`` rows of ``width`` points; a point is ``point_step``
bytes, a row ``row_step`` bytes (``row_step >= width * point_step``: rows may be padded); each
``PointField`` names its byte ``offset`` inside the point, its ``datatype`` (1 INT8, 2 UINT8,
3 INT16, 4 UINT16, 5 INT32, 6 UINT32, 7 FLOAT32, 8 FLOAT64) and ``count``; ``is_bigendian`` gives
the byte order. Nothing about the layout is assumed: bytes between fields are padding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from radarslam.core.errors import InputError

#: PointField.datatype -> numpy type code (without byte order).
DATATYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 8: "f8"}


@dataclass(frozen=True)
class Field:
    """One ``PointField``: ``name``, byte ``offset`` in the point, ``datatype`` (1-8), ``count``."""

    name: str
    offset: int
    datatype: int
    count: int = 1


def cloud_fields(msg) -> list[Field]:
    """The fields of a deserialised PointCloud2 message (any object with ``.fields``)."""
    return [Field(str(f.name), int(f.offset), int(f.datatype), int(f.count)) for f in msg.fields]


def decode(fields: list[Field], data, *, width: int, height: int, point_step: int, row_step: int,
           is_bigendian: bool, names: list[str], where: str) -> dict[str, np.ndarray]:
    """The columns ``names`` of a cloud as float64 arrays of shape ``(height * width,)``.

    Parameters
    ----------
    fields : list of Field
        The cloud's fields (every name in ``names`` must be among them).
    data : bytes-like or uint8 ndarray
        The cloud's ``data``.
    width, height, point_step, row_step : int
        The cloud's layout (bytes for the steps).
    is_bigendian : bool
    names : list of str
        Fields to read.
    where : str
        Prefix of every error message (file, topic, message number).

    Raises
    ------
    InputError
        A field that is missing, of an unknown datatype, with ``count != 1`` or outside the point,
        or ``data`` shorter than the layout declares (a truncated cloud).
    """
    if point_step <= 0 and width * height > 0:
        raise InputError(f"{where}: expected point_step > 0, got {point_step}")
    if row_step < width * point_step:
        raise InputError(f"{where}: expected row_step >= width * point_step = {width * point_step}, got {row_step}")
    buf = np.frombuffer(memoryview(data).cast("B") if not isinstance(data, np.ndarray) else data, dtype=np.uint8)
    need = row_step * (height - 1) + width * point_step if height > 0 and width > 0 else 0
    if buf.size < need:
        raise InputError(f"{where}: expected {need} bytes of point data for {height} x {width} points, "
                         f"got {buf.size} (a truncated or empty cloud)")
    by_name = {f.name: f for f in fields}
    order = ">" if is_bigendian else "<"
    dtype_fields = {"names": [], "formats": [], "offsets": [], "itemsize": max(point_step, 1)}
    for name in names:
        f = by_name.get(name)
        if f is None:
            raise InputError(f"{where}: expected a field {name!r}, got fields {sorted(by_name)}")
        code = DATATYPES.get(f.datatype)
        if code is None:
            raise InputError(f"{where}: field {name!r}: expected a datatype 1-8 (INT8..FLOAT64), got {f.datatype}")
        if f.count != 1:
            raise InputError(f"{where}: field {name!r}: expected count 1, got {f.count}")
        if f.offset < 0 or f.offset + np.dtype(code).itemsize > point_step:
            raise InputError(f"{where}: field {name!r}: expected it inside the {point_step}-byte point, "
                             f"got offset {f.offset} ({code})")
        dtype_fields["names"].append(name)
        dtype_fields["formats"].append(order + code)
        dtype_fields["offsets"].append(f.offset)
    n = width * height
    if n == 0:
        return {name: np.empty(0) for name in names}
    # Each row holds width points of point_step bytes, then row_step - width * point_step bytes of padding.
    rows = np.lib.stride_tricks.as_strided(buf, shape=(height, width * point_step), strides=(row_step, 1))
    packed = np.ascontiguousarray(rows).reshape(-1)
    pts = packed.view(np.dtype(dtype_fields))
    return {name: pts[name].astype(np.float64) for name in names}


def encode(columns: dict[str, np.ndarray], *, datatype: int = 8, pad: int = 0) -> tuple[list[Field], bytes, int]:
    """Pack equal-length columns into PointCloud2 ``(fields, data, point_step)``, little-endian.

    Every field gets ``datatype`` (FLOAT64 by default: the round trip stays exact) and ``pad``
    bytes of padding follow each point (to exercise readers).
    """
    code = DATATYPES[datatype]
    size = np.dtype(code).itemsize
    names = list(columns)
    fields = [Field(name, i * size, datatype) for i, name in enumerate(names)]
    step = size * len(names) + pad
    dt = np.dtype({"names": names, "formats": ["<" + code] * len(names), "offsets": [f.offset for f in fields],
                   "itemsize": step})
    n = len(next(iter(columns.values()))) if names else 0
    arr = np.zeros(n, dtype=dt)
    for name in names:
        arr[name] = columns[name]
    return fields, arr.tobytes(), step
