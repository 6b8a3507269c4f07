"""The stock: a tri-dexel model (three orthogonal dexel grids) of the material left.

Each of the three grids (rays along X, Y and Z through cell centres of pitch h)
stores, per ray, the sorted intervals of material. Material removal is exact along
every ray (``cam.verify.kernels``); the model's only discretisation is the ray
spacing h across the ray. The volume is the mean of the three grids' sums of
interval lengths times h^2.

Constructors: ``Stock.box``, ``Stock.cylinder`` (closed form), ``Stock.from_mesh``
(any closed triangle mesh, e.g. an STL, by ray casting), ``Stock.revolved`` (a
turned blank from a meridional profile) and ``Stock.load`` (a saved ``.npz``
state, docs/formats.md).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam.verify.dexel import TILE as TILE  # re-exported (tests)
from cam.verify.dexel import DexelGrid
from cam.verify.raycast import cast_mesh
from cam.verify.schedule import sweep_grids
from cam.verify.toolshape import ALL_LEVELS, ToolShape, merged_levels
from impeller_cam.atomic import write_bytes_atomic
from impeller_cam.errors import InputError
from impeller_cam.threads import default_threads

#: Version of the saved ``.npz`` stock state.
STATE_VERSION = 1


def _grid_frame(
    lower: NDArray[np.float64], upper: NDArray[np.float64], pitch: float, k: int
) -> tuple[NDArray[np.float64], tuple[int, int], NDArray[np.float64], NDArray[np.float64]]:
    """Origin, shape and ray centre coordinates of grid ``k`` over a box."""
    a, b = (k + 1) % 3, (k + 2) % 3
    n_a = max(1, int(np.ceil((upper[a] - lower[a]) / pitch - 1e-9)))
    n_b = max(1, int(np.ceil((upper[b] - lower[b]) / pitch - 1e-9)))
    # centre the grid on the box so that symmetric stock gives symmetric rays
    origin = np.array(
        [
            0.5 * (lower[a] + upper[a]) - 0.5 * n_a * pitch,
            0.5 * (lower[b] + upper[b]) - 0.5 * n_b * pitch,
        ]
    )
    ca = origin[0] + (np.arange(n_a) + 0.5) * pitch
    cb = origin[1] + (np.arange(n_b) + 0.5) * pitch
    return origin, (n_a, n_b), ca, cb


#: Deflate level of a saved stock: 1 writes nine_blade's finished stock (278 MB of
#: arrays) in 2.6 s of CPU instead of 3.9 s at ``savez_compressed``'s 6, 4 % larger.
NPZ_LEVEL = 1


def _npz_bytes(arrays: dict[str, NDArray[Any]]) -> bytes:
    """A compressed ``.npz`` archive of ``arrays`` (what ``np.savez_compressed``
    writes, at deflate level ``NPZ_LEVEL``; ``np.load`` reads it)."""
    import io
    import zipfile

    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED,
                         compresslevel=NPZ_LEVEL) as archive:
        for name, array in arrays.items():
            with archive.open(f"{name}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.asanyarray(array), allow_pickle=False)
    return buffer.getvalue()


class Stock:
    """Tri-dexel stock model.

    Attributes
    ----------
    grids : tuple of three DexelGrid
        Rays along X, Y and Z.
    pitch : float
        Ray spacing h, mm.
    lower, upper : (3,) float64
        Bounding box of the initial stock, mm.
    owners : list of (str, int)
        NC file name and line of every block swept so far, indexed by the move id
        stored at the interval ends (kept across save/load so an end cut by an
        earlier run is still tied to its line).
    """

    def __init__(
        self,
        grids: tuple[DexelGrid, DexelGrid, DexelGrid],
        pitch: float,
        lower: NDArray[np.float64],
        upper: NDArray[np.float64],
    ) -> None:
        self.grids = grids
        self.pitch = float(pitch)
        self.lower = np.asarray(lower, dtype=np.float64)
        self.upper = np.asarray(upper, dtype=np.float64)
        self.owners: list[tuple[str, int]] = []
        #: Threads of a sweep (at most one per grid at a time; None:
        #: ``default_threads``). The grids are independent, so the result does not
        #: depend on it.
        self.threads: int | None = None

    # ------------------------------------------------------------------ constructors
    @staticmethod
    def _check_pitch(pitch: float) -> None:
        if not (np.isfinite(pitch) and pitch > 0):
            raise InputError(
                "the resolution must be a positive number of mm",
                field="--resolution",
                value=pitch,
                accepted="e.g. 0.1 or 0.05",
            )

    @classmethod
    def box(cls, lower: NDArray[np.float64], upper: NDArray[np.float64], pitch: float) -> Stock:
        """An axis-aligned box ``lower..upper`` at ray spacing ``pitch``.

        Parameters
        ----------
        lower, upper : (3,) float64
            Opposite corners, mm.
        pitch : float
            Ray spacing, mm.

        Returns
        -------
        Stock
        """
        cls._check_pitch(pitch)
        lower = np.asarray(lower, dtype=np.float64)
        upper = np.asarray(upper, dtype=np.float64)
        grids = []
        for k in range(3):
            origin, shape, ca, cb = _grid_frame(lower, upper, pitch, k)
            a, b = (k + 1) % 3, (k + 2) % 3
            inside_a = (ca > lower[a]) & (ca < upper[a])
            inside_b = (cb > lower[b]) & (cb < upper[b])
            mask = (inside_a[:, None] & inside_b[None, :]).ravel()
            rays = np.flatnonzero(mask).astype(np.int64)
            grids.append(
                DexelGrid.from_intervals(
                    k, origin, shape, pitch, rays,
                    np.full(len(rays), lower[k]), np.full(len(rays), upper[k]),
                )
            )
        return cls((grids[0], grids[1], grids[2]), pitch, lower, upper)

    @classmethod
    def cylinder(
        cls, diameter: float, height: float, pitch: float, z0: float = 0.0, bore: float = 0.0
    ) -> Stock:
        """A cylinder on the Z axis from ``z0`` to ``z0 + height``, optional bore.

        Parameters
        ----------
        diameter : float
            Outer diameter, mm.
        height : float
            Height, mm.
        pitch : float
            Ray spacing, mm.
        z0 : float
            Bottom face, mm.
        bore : float
            Bore radius, mm (0: none).

        Returns
        -------
        Stock
        """
        cls._check_pitch(pitch)
        radius = 0.5 * diameter
        if not (radius > 0 and height > 0 and 0 <= bore < radius):
            raise InputError(
                "a cylinder stock needs D > 0, H > 0 and a bore smaller than the radius",
                field="--stock",
                value=(diameter, height, bore),
                accepted="cylinder:D,H with positive D and H",
            )
        lower = np.array([-radius, -radius, z0])
        upper = np.array([radius, radius, z0 + height])
        grids = []
        for k in range(3):
            origin, shape, ca, cb = _grid_frame(lower, upper, pitch, k)
            grid_a, grid_b = np.meshgrid(ca, cb, indexing="ij")
            ga, gb = grid_a.ravel(), grid_b.ravel()
            rays_all = np.arange(len(ga), dtype=np.int64)
            if k == 2:  # (x, y) columns
                rr = ga * ga + gb * gb
                keep = (rr < radius * radius) & (rr >= bore * bore)
                rays = rays_all[keep]
                lo = np.full(len(rays), z0)
                hi = np.full(len(rays), z0 + height)
            else:  # k = 0: (y, z); k = 1: (z, x): one coordinate across, z the other
                across, zz = (ga, gb) if k == 0 else (gb, ga)
                keep = (np.abs(across) < radius) & (zz > z0) & (zz < z0 + height)
                outer = np.sqrt(np.maximum(radius * radius - across * across, 0.0))
                inner = np.sqrt(np.maximum(bore * bore - across * across, 0.0))
                split = keep & (np.abs(across) < bore)
                whole = keep & ~split
                rays = np.concatenate([rays_all[whole], rays_all[split], rays_all[split]])
                lo = np.concatenate([-outer[whole], -outer[split], inner[split]])
                hi = np.concatenate([outer[whole], -inner[split], outer[split]])
                order = np.lexsort((lo, rays))
                rays, lo, hi = rays[order], lo[order], hi[order]
            grids.append(DexelGrid.from_intervals(k, origin, shape, pitch, rays, lo, hi))
        return cls((grids[0], grids[1], grids[2]), pitch, lower, upper)

    @classmethod
    def from_mesh(
        cls, vertices: NDArray[np.float64], faces: NDArray[np.int64], pitch: float
    ) -> Stock:
        """Any closed triangle mesh (mm) by casting the three ray grids through it.

        Parameters
        ----------
        vertices : (v, 3) float64
            Mesh vertices, mm.
        faces : (f, 3) int64
            Triangles (vertex indices).
        pitch : float
            Ray spacing, mm.

        Returns
        -------
        Stock
        """
        cls._check_pitch(pitch)
        vertices = np.asarray(vertices, dtype=np.float64)
        faces = np.asarray(faces, dtype=np.int64)
        if len(faces) == 0:
            raise InputError("the stock mesh has no triangles", field="--stock")
        lower, upper = vertices.min(axis=0), vertices.max(axis=0)
        grids = []
        for k in range(3):
            origin, shape, _, _ = _grid_frame(lower, upper, pitch, k)
            rays, lo, hi = cast_mesh(vertices, faces, k, origin, shape, pitch)
            grids.append(DexelGrid.from_intervals(k, origin, shape, pitch, rays, lo, hi))
        return cls((grids[0], grids[1], grids[2]), pitch, lower, upper)

    @classmethod
    def revolved(
        cls, profile: NDArray[np.float64], pitch: float, sections: int = 1440
    ) -> Stock:
        """A turned solid: a closed meridional polygon revolved about Z.

        Parameters
        ----------
        profile : (k, 2) float64
            ``(r, z)`` polygon, mm.
        pitch : float
            Ray spacing, mm.
        sections : int
            Facets around (1440 facets at r = 100 mm deviate from the circle by
            0.0024 mm).

        Returns
        -------
        Stock
        """
        import trimesh

        profile = np.asarray(profile, dtype=np.float64)
        mesh = trimesh.creation.revolve(profile, sections=sections)
        if not mesh.is_volume:
            raise InputError(
                "the revolved stock profile does not enclose a volume",
                field="stock profile",
                value=profile.shape,
            )
        return cls.from_mesh(mesh.vertices, mesh.faces, pitch)

    # ------------------------------------------------------------------ queries
    def volume(self) -> float:
        """Material volume: mean of the three grids' estimates.

        Returns
        -------
        float
            mm^3.
        """
        return float(np.mean([g.volume() for g in self.grids]))

    def surface_points(self) -> tuple[NDArray[np.float64], NDArray[np.int32]]:
        """``surface_samples`` without the normals: the points and move ids of all the
        interval ends, written once into arrays of their final size.

        Returns
        -------
        points : (n, 3) float64
            mm, in ``surface_samples`` order with the same values.
        moves : (n,) int32
        """
        total = sum(g.n_ends() for g in self.grids)
        points = np.empty((total, 3))
        moves = np.empty(total, np.int32)
        offset = 0
        for grid in self.grids:
            offset += grid.fill_ends(points, moves, offset)
        return points, moves

    def surface_samples(
        self,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int32]]:
        """Interval ends of all three grids.

        Returns
        -------
        points : (n, 3) float64
            mm.
        normals : (n, 3) float64
            Unit outward normals.
        moves : (n,) int32
            Id of the move that made each end (index of ``owners``; -1: initial).
        """
        parts = [g.ends() for g in self.grids]
        return (
            np.vstack([p[0] for p in parts]),
            np.vstack([p[1] for p in parts]),
            np.concatenate([p[2] for p in parts]),
        )

    def memory_bytes(self) -> int:
        """Bytes held by the three grids' arrays.

        Returns
        -------
        int
        """
        return int(
            sum(
                g.lo.nbytes + g.hi.nbytes + g.lo_move.nbytes + g.hi_move.nbytes
                + g.start.nbytes + g.count.nbytes + g.cap.nbytes
                for g in self.grids
            )
        )

    # ------------------------------------------------------------------ material removal
    def sweep(
        self,
        tips: NDArray[np.float64],
        moves: NDArray[np.float64],
        axes: NDArray[np.float64],
        move_ids: NDArray[np.int32],
        shape: ToolShape,
        probe_pitch: float = 0.5,
        batch: int | None = None,
        done: Callable[[int], None] | None = None,
        parts: NDArray[np.int8] | None = None,
    ) -> NDArray[np.float64]:
        """Sweep the tool along straight fixed-axis moves: cut with the cutter, probe
        with shank and holder.

        Parameters
        ----------
        tips : (m, 3) float64
            Tool tip at the start of each move, mm.
        moves : (m, 3) float64
            Tip displacement of each move, mm.
        axes : (m, 3) float64
            Unit tool axis held during each move.
        move_ids : (m,) int32
            Id recorded at the interval ends each move creates.
        shape : ToolShape
            The tool's primitives.
        probe_pitch : float
            Ray spacing, mm, on which shank and holder are probed (every
            ``round(probe_pitch / h)``-th ray; contacts narrower than this across the
            rays can be missed). Cutting always uses every ray.
        batch : int, optional
            Moves per compiled call (``None``: all at once). The grids advance through
            the batches independently (``cam.verify.schedule``): the same result.
        done : callable, optional
            Progress: called with the number of leading moves every grid has swept.
        parts : (m,) int8, optional
            The levels each move sweeps (``ToolMoves.part``: bit ``l`` for the
            primitives of level ``l``, ``ToolShape.cutter_level``; the body is level
            0). None: the whole tool on every move.

        Returns
        -------
        (m, 3) float64
            Per move: removed volume (mm^3, mean of the grids), the longest cut along
            any ray (mm) and the longest overlap of shank/holder with the stock (mm).
        """
        tips = np.ascontiguousarray(tips, dtype=np.float64).reshape(-1, 3)
        moves = np.ascontiguousarray(moves, dtype=np.float64).reshape(-1, 3)
        axes = np.ascontiguousarray(axes, dtype=np.float64).reshape(-1, 3)
        ids = np.ascontiguousarray(move_ids, dtype=np.int32).reshape(-1)
        whole = parts is None or bool(np.all(np.asarray(parts) == ALL_LEVELS))
        cutter = merged_levels(shape.cutter) if whole else shape.cutter
        prims = np.ascontiguousarray(np.vstack([cutter, shape.body]))
        cuts = np.zeros(len(prims), np.bool_)
        cuts[: len(cutter)] = True
        strides = np.ones(len(prims), np.int64)
        strides[len(cutter) :] = max(1, int(round(probe_pitch / self.pitch)))
        masks = np.full(len(tips), (1 << len(prims)) - 1, np.int64)
        if not whole:
            level = np.zeros(len(prims), np.int64)
            level[: len(shape.cutter_level)] = shape.cutter_level
            bits = np.asarray(parts, np.int64).reshape(-1)
            # the primitives of every level a move's bits name
            by_bits = np.array([sum(1 << p for p in range(len(prims)) if (b >> level[p]) & 1)
                                for b in range(int(bits.max(initial=0)) + 1)], np.int64)
            masks = by_bits[bits]
        out = np.zeros((len(tips), 3))
        job = (tips, moves, axes, ids, prims, cuts, strides, masks)
        threads = self.threads if self.threads is not None else default_threads()
        per_grid = sweep_grids(self.grids, job, batch, threads, done)
        for grid, stats in zip(self.grids, per_grid, strict=True):  # fixed order
            out[:, 0] += stats[:, 0] * grid.pitch**2 / 3.0
            out[:, 1] = np.maximum(out[:, 1], stats[:, 1])
            out[:, 2] = np.maximum(out[:, 2], stats[:, 3])
        return out

    # ------------------------------------------------------------------ state I/O
    def save(self, path: str | Path) -> Path:
        """Write the state to ``path`` (``.npz``, atomically; docs/formats.md).

        Parameters
        ----------
        path : str or Path
            The ``.npz`` file.

        Returns
        -------
        Path
            ``path``.
        """
        arrays: dict[str, NDArray[Any]] = {
            "version": np.array([STATE_VERSION], np.int64),
            "pitch": np.array([self.pitch]),
            "bounds": np.vstack([self.lower, self.upper]),
            "owner_names": np.array([name for name, _ in self.owners], dtype=np.str_),
            "owner_lines": np.array([line for _, line in self.owners], dtype=np.int64),
        }
        for k, grid in enumerate(self.grids):
            arrays.update(grid.to_arrays(f"g{k}"))
        return write_bytes_atomic(path, _npz_bytes(arrays))

    @classmethod
    def load(cls, path: str | Path) -> Stock:
        """Read a state written by ``save``.

        Parameters
        ----------
        path : str or Path
            The ``.npz`` file.

        Returns
        -------
        Stock
        """
        path = Path(path)
        try:
            with np.load(path) as data:
                arrays = {key: data[key] for key in data.files}
        except (OSError, ValueError) as error:
            raise InputError(f"cannot read stock state: {error}", file=path) from None
        version = int(arrays.get("version", np.array([0]))[0])
        if version != STATE_VERSION or "pitch" not in arrays:
            raise InputError(
                "not an impeller-cam stock state",
                file=path,
                field="version",
                value=version,
                accepted=f"version {STATE_VERSION} written by `impeller-cam verify`",
            )
        pitch = float(arrays["pitch"][0])
        grids = tuple(DexelGrid.from_arrays(arrays, f"g{k}", pitch) for k in range(3))
        bounds = arrays["bounds"]
        stock = cls((grids[0], grids[1], grids[2]), pitch, bounds[0], bounds[1])
        names = arrays.get("owner_names", np.zeros(0, np.str_))
        lines = arrays.get("owner_lines", np.zeros(0, np.int64))
        stock.owners = [(str(n), int(v)) for n, v in zip(names, lines, strict=True)]
        return stock
