"""STEP (mm) and STL export of the impeller, written atomically and deterministically.

OpenCASCADE writes the time of writing into the STEP header (``FILE_NAME``) and
numbers the products it transfers within a process; both are replaced by fixed
values (time stamp ``1970-01-01T00:00:00``, product ``impeller``) so that the same
solid always gives the same bytes. The writer's console statistics are silenced.
"""

from __future__ import annotations

import re
import tempfile
from pathlib import Path

import trimesh
from OCP.IFSelect import IFSelect_RetDone
from OCP.Interface import Interface_Static
from OCP.Message import Message, Message_Gravity
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Reader, STEPControl_Writer
from OCP.TopoDS import TopoDS_Shape

from impeller_cam.atomic import write_bytes_atomic

__all__ = ["read_step", "write_step", "write_stl"]


_STAMP = re.compile(rb"(FILE_NAME\('[^']*',)'[^']*'")
_PRODUCT = re.compile(rb"Open CASCADE STEP translator [0-9.]+ [0-9]+")


def _quiet() -> None:
    """Only failures from OpenCASCADE's default messenger (no transfer statistics)."""
    printers = Message.DefaultMessenger_s().Printers()
    for printer in printers:
        printer.SetTraceLevel(Message_Gravity.Message_Fail)


def write_step(shape: TopoDS_Shape, path: str | Path) -> Path:
    """Write ``shape`` as an AP214 STEP file in millimetres (atomic, deterministic).

    Parameters
    ----------
    shape : TopoDS_Shape
        The shape (mm).
    path : str or Path
        The STEP file.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    _quiet()
    Interface_Static.SetCVal_s("write.step.unit", "MM")
    Interface_Static.SetCVal_s("write.step.schema", "AP214IS")
    writer = STEPControl_Writer()
    writer.Transfer(shape, STEPControl_AsIs)
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp) / "impeller.step"
        if writer.Write(str(scratch)) != IFSelect_RetDone:
            raise RuntimeError(f"STEP writer failed for {path}")
        data = scratch.read_bytes()
    data = _STAMP.sub(rb"\1'1970-01-01T00:00:00'", data, count=1)
    data = _PRODUCT.sub(b"impeller", data)
    return write_bytes_atomic(path, data)


def read_step(path: str | Path) -> TopoDS_Shape:
    """Read a STEP file back into one shape.

    Parameters
    ----------
    path : str or Path
        The STEP file.

    Returns
    -------
    TopoDS_Shape
        Its shapes as one (mm).
    """
    _quiet()
    reader = STEPControl_Reader()
    if reader.ReadFile(str(path)) != IFSelect_RetDone:
        raise RuntimeError(f"cannot read STEP file {path}")
    reader.TransferRoots()
    return reader.OneShape()


def write_stl(mesh: trimesh.Trimesh, path: str | Path) -> Path:
    """Write a binary STL (mm) atomically.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The mesh, mm.
    path : str or Path
        The STL file.

    Returns
    -------
    Path
        ``path``.
    """
    data = mesh.export(file_type="stl")
    if not isinstance(data, bytes):
        raise TypeError("trimesh did not export binary STL")
    return write_bytes_atomic(path, data)
