"""A ParaView script in every result directory: ``pvpython view.py`` (or *Run Script* in ParaView's Python shell).

It opens ``solution.xdmf`` beside it with the reader ParaView picks for .xdmf files, warps the body by the
displacement (the scale that makes the largest displacement a tenth of the body, written into the script),
colours it by ``contact_state`` as categories with the labels open / stick / slip (grey: not a contact node)
and, for a load path, sets the time slider to the solves (the last one shown). ``pvpython view.py --screenshot
FILE.png`` saves the view and prints one JSON line (the arrays, the times, the categories) for a check.
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from fenics_coulomb.io.fields import CONTACT_STATES
from fenics_coulomb.io.results import rank0_file
from fenics_coulomb.model.contact_model import ContactModel

__all__ = ["STATE_RGB", "VIEW_SCRIPT", "largest_force_normal", "warp_scale", "write_view_script"]

#: The contact states' colours (RGB), the same as the figures': open blue, stick red, slip gold; grey elsewhere.
STATE_RGB = {-1: (0.75, 0.75, 0.75), 0: (0.12, 0.47, 0.71), 1: (0.84, 0.15, 0.16), 2: (1.0, 0.84, 0.0)}

VIEW_SCRIPT = '''"""Open the results beside this file in ParaView: pvpython view.py [--screenshot FILE.png]
(written by fenics-coulomb; also runs from ParaView's Python shell)."""
import json
import os
import sys

from paraview.simple import (ColorBy, GetActiveViewOrCreate, GetAnimationScene, GetColorTransferFunction,
                             GetScalarBar, OpenDataFile, Render, ResetCamera, SaveScreenshot, Show, WarpByVector)

HERE = os.path.dirname(os.path.abspath(__file__))
SCALE = {scale!r}
VIEW, UP = {view!r}, {up!r}  # the camera looks at the contact side (fenics_coulomb.io.figures.contact_view)
STATES = {states!r}
RGB = {rgb!r}

reader = OpenDataFile(os.path.join(HERE, "solution.xdmf"))
scene = GetAnimationScene()
scene.UpdateAnimationUsingDataTimeSteps()
times = list(getattr(reader, "TimestepValues", []) or [])
if times:
    scene.AnimationTime = times[-1]
warp = WarpByVector(Input=reader)
warp.Vectors = ["POINTS", "displacement"]
warp.ScaleFactor = SCALE
view = GetActiveViewOrCreate("RenderView")
display = Show(warp, view)
ColorBy(display, ("POINTS", "contact_state"))
lut = GetColorTransferFunction("contact_state")
lut.InterpretValuesAsCategories = 1
lut.Annotations = [str(item) for key, label in STATES for item in (key, label)]
lut.IndexedColors = [c for key, _ in STATES for c in RGB[str(key)]]
display.InterpolateScalarsBeforeMapping = 1  # a category per pixel, no blended colours between the states
display.SetScalarBarVisibility(view, True)
bar = GetScalarBar(lut, view)
bar.TitleFontSize, bar.LabelFontSize = 12, 10
view.CameraFocalPoint = [0.0, 0.0, 0.0]
view.CameraPosition = list(VIEW)
view.CameraViewUp = list(UP)
ResetCamera()
Render()
if "--screenshot" in sys.argv:
    path = sys.argv[sys.argv.index("--screenshot") + 1]
    SaveScreenshot(path, view, ImageResolution=[1000, 700])
    arrays = [a.GetName() for a in warp.PointData]
    print("VIEW " + json.dumps({{"arrays": arrays, "times": times, "annotations": list(lut.Annotations),
                                "categorical": int(lut.InterpretValuesAsCategories), "scale": SCALE, "view": list(VIEW),
                                "colored_by": list(display.ColorArrayName)}}), flush=True)
'''


def warp_scale(model: ContactModel, displacements: list[npt.NDArray[np.float64]]) -> float:
    """The warp factor that makes the largest displacement (over ``displacements``, owned DOFs) a tenth of the
    body's extent (collective; 1 without displacement)."""
    comm = model.comm
    x = model.V.mesh.geometry.x
    lo, hi = np.empty(3), np.empty(3)
    comm.Allreduce(np.ascontiguousarray(x.min(axis=0, initial=np.inf)), lo, op=MPI.MIN)
    comm.Allreduce(np.ascontiguousarray(x.max(axis=0, initial=-np.inf)), hi, op=MPI.MAX)
    size = float(np.max(hi - lo)) if np.all(np.isfinite(hi - lo)) else 1.0
    local = max((float(np.max(np.linalg.norm(np.asarray(u).reshape(-1, 3), axis=1), initial=0.0))
                 for u in displacements), default=0.0)
    umax = comm.allreduce(local, op=MPI.MAX)
    return 0.1 * size / umax if umax > 0 and np.isfinite(umax) else 1.0


def largest_force_normal(model: ContactModel, contact_force: npt.NDArray[np.float64]) -> list[float] | None:
    """The contact normal of the node with the largest contact force, on every rank (collective; None without
    contact nodes)."""
    force = np.linalg.norm(np.asarray(contact_force, dtype=np.float64).reshape(-1, 3), axis=1)
    best = (float(force.max()), model.contact.normals[int(np.argmax(force))].tolist()) if force.size else (-1.0, None)
    return max(model.comm.allgather(best), key=lambda item: item[0])[1]


@rank0_file
def write_view_script(path: Path, scale: float, normal: npt.ArrayLike | None, comm: MPI.Comm) -> None:
    """Write the ParaView script ``path`` (``view.py`` of a result set) on rank 0 with the warp ``scale`` and the
    camera of :func:`~fenics_coulomb.io.figures.contact_view` for ``normal``."""
    from fenics_coulomb.io.figures import contact_view

    if comm.rank != 0:
        return
    view, up = contact_view(normal)
    states = [(key, label) for key, label in CONTACT_STATES.items()]
    rgb = {str(key): list(colour) for key, colour in STATE_RGB.items()}
    Path(path).write_text(VIEW_SCRIPT.format(scale=float(scale), states=states, rgb=rgb,
                                             view=[float(c) for c in view], up=[float(c) for c in up]))
