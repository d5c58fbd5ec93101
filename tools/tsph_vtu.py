"""Reads tsph output with numpy only: .pvd collections and .vtu files in VTK XML
UnstructuredGrid format with raw appended binary data (header_type UInt64).

    import tsph_vtu
    for time, path in tsph_vtu.read_pvd("out/bar/particles.pvd"):
        grid = tsph_vtu.read_vtu(path)
        grid.points        # (n, 3)
        grid.point_data    # {"velocity": (n, 3), "stress": (n, 6), "id": (n,), ...}
"""
import os
import xml.etree.ElementTree as ET

import numpy as np

_TYPES = {"Float64": "<f8", "Float32": "<f4", "Int64": "<i8", "Int32": "<i4",
          "UInt64": "<u8", "UInt32": "<u4", "UInt8": "u1"}


class Grid:
    def __init__(self, points, point_data, cells):
        self.points = points
        self.point_data = point_data
        self.cells = cells  # {"connectivity", "offsets", "types"}


def read_vtu(path):
    with open(path, "rb") as f:
        raw = f.read()
    marker = raw.index(b'<AppendedData encoding="raw">')
    start = raw.index(b"_", marker) + 1
    end = raw.rindex(b"</AppendedData>")
    header = raw[:marker].decode() + "</VTKFile>"
    root = ET.fromstring(header)
    if root.get("type") != "UnstructuredGrid" or root.get("byte_order") != "LittleEndian":
        raise ValueError(f"{path}: not a little-endian UnstructuredGrid")
    if root.get("header_type") != "UInt64":
        raise ValueError(f"{path}: header_type must be UInt64")
    piece = root.find("UnstructuredGrid/Piece")
    n_points = int(piece.get("NumberOfPoints"))
    n_cells = int(piece.get("NumberOfCells"))

    def array(element, count):
        if element.get("format") != "appended":
            raise ValueError(f"{path}: {element.get('Name')} is not appended")
        offset = start + int(element.get("offset"))
        nbytes = int(np.frombuffer(raw, "<u8", 1, offset)[0])
        dtype = np.dtype(_TYPES[element.get("type")])
        components = int(element.get("NumberOfComponents", "1"))
        if nbytes != count * components * dtype.itemsize:
            raise ValueError(f"{path}: {element.get('Name')}: block of {nbytes} bytes, "
                             f"expected {count} x {components} x {dtype.itemsize}")
        if offset + 8 + nbytes > end:
            raise ValueError(f"{path}: {element.get('Name')} runs past the appended data")
        values = np.frombuffer(raw, dtype, count * components, offset + 8)
        return values.reshape(count, components) if components > 1 else values

    points = array(piece.find("Points/DataArray"), n_points)
    data = {e.get("Name"): array(e, n_points) for e in piece.findall("PointData/DataArray")}
    cells = {e.get("Name"): array(e, n_cells) for e in piece.findall("Cells/DataArray")}
    return Grid(points, data, cells)


def read_pvd(path):
    """[(time, absolute path of the .vtu)] in file order."""
    root = ET.parse(path).getroot()
    base = os.path.dirname(path)
    return [(float(d.get("timestep")), os.path.join(base, d.get("file")))
            for d in root.iter("DataSet")]
