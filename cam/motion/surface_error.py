"""Where a contour error shapes the part: the ball on the design surface, or air.

A deviation of the tool from its commanded path leaves a mark only where the cutter
touches the finished surface, and there only its component along the surface normal
does: a ball-end mill displaced *along* the surface still touches it (its contact
point moves; on a surface of curvature radius rho a tangential shift ``s`` changes
the depth by about ``s^2 / (2 rho)``: 1 um for 0.2 mm on 20 mm), one displaced *along
the normal* cuts that much too deep or leaves that much standing. So:

1. **Contact** (``block_contact``): the ball centre of each feed block's commanded
   end pose, ``tip + R axis``, is queried against the design mesh
   (``cam.verify.deviation.DesignDistance``); the block is *in contact* when the gap
   ``distance - R`` is at most ``CONTACT_GAP`` (the ball touches the design surface:
   the finishing programs have no allowance), *air* otherwise (approaches,
   departures, links above the part). The contact normal is the outward normal of
   the closest design face.
2. **Surface error** (``surface_component``): per sample, the deviation of the
   simulated ball centre from the closest point of the commanded path (the contour
   error's vector at the tip plus ``R`` times the tool-axis change there) projected on
   the contact normal of the sample's block; per block the largest magnitude.

Air blocks keep their full contour error (reported apart, never dropped); an air
block whose predicted error exceeds its gap could reach the design surface and is
counted as such (``reach_part``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from cam.motion.contour import ContourError
    from cam.verify.deviation import DesignDistance

__all__ = ["CONTACT_GAP", "BlockContact", "block_contact", "surface_component"]

#: Largest gap between the commanded ball and the design surface of a block in
#: contact, mm (twice the programs' ``G64 P0.01``: the chord and rounding tolerance).
CONTACT_GAP = 0.02


@dataclass(frozen=True)
class BlockContact:
    """Contact of each block's commanded ball with the design surface.

    Attributes
    ----------
    gap : (n,) float64
        Distance of the ball from the design surface at the block's end, mm
        (negative: inside the design; NaN for rapids).
    normal : (n, 3) float64
        Outward unit normal of the closest design face (zero for rapids).
    contact : (n,) bool
        Feed block whose ball touches the design surface (``gap <= CONTACT_GAP``).
    radius : float
        Ball radius, mm.
    """

    gap: NDArray[np.float64]
    normal: NDArray[np.float64]
    contact: NDArray[np.bool_]
    radius: float


def _face_normals(design: DesignDistance) -> NDArray[np.float64]:
    """Outward unit normal per input face of the design (its sub-triangles share it)."""
    normal = np.zeros((int(design.source_face.max()) + 1, 3))
    normal[design.source_face] = design.normals
    return normal


def block_contact(
    tip: NDArray[np.float64], axis: NDArray[np.float64], feed: NDArray[np.bool_],
    radius: float, design: DesignDistance, gap: float = CONTACT_GAP,
) -> BlockContact:
    """Which feed blocks put the ball on the design surface (module doc, step 1).

    Parameters
    ----------
    tip, axis : (n, 3) float64
        Commanded tool tip (mm) and unit tool axis (tip towards spindle) at each
        block's end, workpiece frame.
    feed : (n,) bool
        Feed blocks (rapids are never in contact).
    radius : float
        Ball radius of the cutter, mm.
    design : DesignDistance
        Signed distance from the design mesh (and its faces' normals).
    gap : float
        Largest ball-to-surface gap counted as contact, mm.

    Returns
    -------
    BlockContact
    """
    n = len(tip)
    distance = np.full(n, np.nan)
    normal = np.zeros((n, 3))
    rows = np.flatnonzero(feed)
    if len(rows):
        centre = tip[rows] + radius * axis[rows]
        d, face = design.closest(centre)
        distance[rows] = d - radius
        normal[rows] = _face_normals(design)[face]
    contact = feed & (np.nan_to_num(distance, nan=np.inf) <= gap)
    return BlockContact(gap=distance, normal=normal, contact=contact, radius=float(radius))


def surface_component(error: ContourError, block: NDArray[np.int64],
                      contact: BlockContact) -> NDArray[np.float64]:
    """Deviation of the simulated ball centre along the contact normal, per sample, mm.

    Parameters
    ----------
    error : ContourError
        Per-sample contour error with its vectors (``offset``, ``axis_offset``).
    block : (m,) int64
        Block of each sample.
    contact : BlockContact

    Returns
    -------
    (m,) float64
        ``(e_tip + R (a_sim - a_cmd)) . n`` of the sample's block, signed: positive
        away from the part (material left), negative into it (a gouge); zero on
        samples of blocks not in contact.
    """
    centre = error.offset + contact.radius * error.axis_offset
    normal = contact.normal[block]
    return np.where(contact.contact[block], np.einsum("ij,ij->i", centre, normal), 0.0)
