"""A ParaView script in every result directory: ``pvpython view.py`` (or *Run Script* in ParaView's Python shell).

It opens ``solution.xdmf`` beside it with Xdmf3ReaderS (the reader pvpython picks for .xdmf files; named, so that
the GUI asks nothing), warps the body by the
displacement (by the true displacement beside obstacles, which the body then meets where it touches them; else
by the scale that makes the largest displacement a tenth of the body; written into the script),
colours it by ``contact_state`` as categories with the labels open / stick / slip (grey: not a contact node)
and, for a load path, sets the time slider to the solves (the last one shown). Beside the body it opens
``obstacles.xdmf`` when the set has one: the rigid obstacles' surfaces as placed at each time (translucent,
coloured by their ``octant`` pattern, which turns with a rolling obstacle). A mesh of several bodies is shown
body by body (``Threshold`` on the ``body`` field): the bodies with contact nodes (the slave sides) opaque and
coloured by state, the others translucent, so that the camera, on the master side, sees the slave surface
through them. The camera looks along the contact normal of the node with the largest force, from the
obstacle's (master's) side.

``paraview --script=view.py`` builds this pipeline in the ParaView window; ``pvpython view.py --screenshot
FILE.png`` renders it without a window, headless too (ParaView renders through X: without ``DISPLAY`` the script
starts a private Xvfb, stopped when it ends), saves the view and prints one JSON line (the pipeline's sources, the
arrays, the times, the categories, the bodies' parts, the obstacles' points at the last time) for a check.
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from fenics_coulomb.io.fields import CONTACT_STATES
from fenics_coulomb.io.results import rank0_file
from fenics_coulomb.model.contact_model import ContactModel

__all__ = ["OBSTACLE_OPACITY", "STATE_RGB", "VIEW_SCRIPT", "contact_bodies", "largest_force_normal", "warp_scale",
           "write_view_script"]

#: The contact states' colours (RGB), the same as the figures': open blue, stick red, slip gold; grey elsewhere.
STATE_RGB = {-1: (0.75, 0.75, 0.75), 0: (0.12, 0.47, 0.71), 1: (0.84, 0.15, 0.16), 2: (1.0, 0.84, 0.0)}

#: The opacity of the obstacles and of the bodies without contact nodes (the camera looks through them).
OBSTACLE_OPACITY = 0.35

VIEW_SCRIPT = '''"""Open the results beside this file in ParaView: `paraview --script=view.py` (the GUI), or
`pvpython view.py --screenshot FILE.png` (headless: an Xvfb is started when there is no display)
(written by fenics-coulomb; also runs from ParaView's Python shell)."""
import atexit
import json
import os
import shutil
import subprocess
import sys


def virtual_display():
    """ParaView renders through X: without a display, start a private Xvfb for this process (stopped at exit)."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        sys.exit("view.py: no display (DISPLAY is not set) and no Xvfb to render off screen: install xvfb, or "
                 "run it as `xvfb-run -a pvpython view.py --screenshot view.png`")
    read, write = os.pipe()
    proc = subprocess.Popen([xvfb, "-displayfd", str(write), "-screen", "0", "1280x1024x24", "-nolisten", "tcp",
                             "-noreset"], pass_fds=(write,), stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    os.close(write)
    number = b""
    while not number.endswith(b"\\n"):
        chunk = os.read(read, 16)
        if not chunk:
            break
        number += chunk
    os.close(read)
    atexit.register(proc.kill)
    if not number.strip().isdigit():
        sys.exit("view.py: Xvfb did not start; run it as `xvfb-run -a pvpython view.py --screenshot view.png`")
    os.environ["DISPLAY"] = ":" + number.decode().strip()


if not os.environ.get("DISPLAY"):
    virtual_display()

from paraview import servermanager
from paraview.simple import (ColorBy, GetActiveViewOrCreate, GetColorTransferFunction, GetScalarBar, GetSources,
                             GetTimeKeeper, Render, SaveScreenshot, Show, Threshold, WarpByVector, Xdmf3ReaderS)

# beside this file; ParaView's GUI (paraview --script=view.py) gives a script no __file__: then the current directory
HERE = os.path.dirname(os.path.abspath(__file__)) if "__file__" in globals() else os.getcwd()
SCALE = {scale!r}
VIEW, UP = {view!r}, {up!r}  # the camera looks at the contact side (fenics_coulomb.io.figures.contact_view)
STATES = {states!r}
RGB = {rgb!r}
BODIES = {bodies!r}  # several bodies: every body's number; the slave sides (bodies with contact nodes)
SLAVES = {slaves!r}
OPACITY = {opacity!r}


def state_colours(display, view):
    """Colour a display by contact_state as the labelled categories."""
    ColorBy(display, ("POINTS", "contact_state"))
    lut = GetColorTransferFunction("contact_state")
    lut.InterpretValuesAsCategories = 1
    lut.Annotations = [str(item) for key, label in STATES for item in (key, label)]
    lut.IndexedColors = [c for key, _ in STATES for c in RGB[str(key)]]
    display.InterpolateScalarsBeforeMapping = 1  # a category per pixel, no blended colours between the states
    display.SetScalarBarVisibility(view, True)
    bar = GetScalarBar(lut, view)
    bar.TitleFontSize, bar.LabelFontSize = 12, 10
    return lut


view = GetActiveViewOrCreate("RenderView")
reader = Xdmf3ReaderS(registrationName="solution.xdmf", FileName=[os.path.join(HERE, "solution.xdmf")])
obstacles = None
if os.path.exists(os.path.join(HERE, "obstacles.xdmf")):
    obstacles = Xdmf3ReaderS(registrationName="obstacles.xdmf", FileName=[os.path.join(HERE, "obstacles.xdmf")])
times = list(getattr(reader, "TimestepValues", []) or [])
time = times[-1] if times else 0.0
GetTimeKeeper().Time = time  # the last solve (the time keeper, not the animation scene: that hangs the GUI)
view.ViewTime = time
warp = WarpByVector(Input=reader)
warp.Vectors = ["POINTS", "displacement"]
warp.ScaleFactor = SCALE
parts = {{}}
lut = GetColorTransferFunction("contact_state")
if BODIES:
    for body in BODIES:
        part = Threshold(Input=warp, registrationName=f"body {{body}}")
        part.Scalars = ["POINTS", "body"]
        part.LowerThreshold = part.UpperThreshold = body
        parts[body] = part
        display = Show(part, view)
        if body in SLAVES:
            lut = state_colours(display, view)
        else:
            ColorBy(display, None)
            display.AmbientColor = display.DiffuseColor = [0.8, 0.8, 0.8]
            display.Opacity = OPACITY
    colored = parts[SLAVES[0]] if SLAVES else warp
else:
    display = Show(warp, view)
    lut = state_colours(display, view)
    colored = warp
if obstacles is not None:
    shown = Show(obstacles, view)
    ColorBy(shown, ("POINTS", "octant"))
    pattern = GetColorTransferFunction("octant")
    pattern.InterpretValuesAsCategories = 1
    pattern.Annotations = ["0", "", "1", ""]
    pattern.IndexedColors = [0.55, 0.55, 0.6, 0.9, 0.9, 0.95]
    shown.SetScalarBarVisibility(view, False)
    shown.Opacity = OPACITY
view.CameraFocalPoint = [0.0, 0.0, 0.0]
view.CameraPosition = list(VIEW)
view.CameraViewUp = list(UP)
colored.UpdatePipeline(time)
view.ResetCamera(*colored.GetDataInformation().GetBounds())  # on the body (the obstacles may reach far)
view.CameraPosition = [f + 1.3 * (p - f) for p, f in zip(view.CameraPosition, view.CameraFocalPoint)]
Render()
if "--screenshot" in sys.argv:
    path = sys.argv[sys.argv.index("--screenshot") + 1]
    SaveScreenshot(path, view, ImageResolution=[1000, 700])

    def fetched(source):
        source.UpdatePipeline(time)
        return servermanager.Fetch(source)

    def point_array(data, name):
        array = data.GetPointData().GetArray(name)
        return [list(array.GetTuple(i)) for i in range(array.GetNumberOfTuples())]

    report = {{"sources": sorted(name for name, _ in GetSources()), "arrays": [a.GetName() for a in warp.PointData],
              "times": times, "time": time, "annotations": list(lut.Annotations),
              "categorical": int(lut.InterpretValuesAsCategories), "scale": SCALE, "view": list(VIEW),
              "colored_by": list(servermanager.GetRepresentation(colored, view).ColorArrayName),
              "bodies": {{}}}}
    for body, part in parts.items():
        data = fetched(part)
        states = data.GetPointData().GetArray("contact_state")
        report["bodies"][str(body)] = {{
            "points": data.GetNumberOfPoints(), "bounds": list(data.GetBounds()),
            "state_range": list(states.GetRange()) if states is not None else None,
            "state_counts": {{str(k): sum(1 for i in range(states.GetNumberOfTuples()) if states.GetTuple1(i) == k)
                             for k, _ in STATES}} if states is not None else None,
            "colored_by": list(servermanager.GetRepresentation(part, view).ColorArrayName),
            "opacity": servermanager.GetRepresentation(part, view).Opacity}}
    if obstacles is not None:
        data = fetched(obstacles)
        points = data.GetPoints()
        report["obstacles"] = {{
            "times": list(getattr(obstacles, "TimestepValues", []) or []),
            "points": [list(points.GetPoint(i)) for i in range(points.GetNumberOfPoints())],
            "rest_position": point_array(data, "rest_position"),
            "obstacle": [int(v[0]) for v in point_array(data, "obstacle")],
            "visible": int(servermanager.GetRepresentation(obstacles, view).Visibility)}}
    print("VIEW " + json.dumps(report), flush=True)
'''


def warp_scale(model: ContactModel, displacements: list[npt.NDArray[np.float64]]) -> float:
    """The warp factor of view.py: 1 when the result set shows obstacles (the body then meets them where it
    touches them), else the factor that makes the largest displacement (over ``displacements``, owned DOFs) a tenth
    of the body's extent (collective; 1 without displacement)."""
    comm = model.comm
    if model.obstacles:
        return 1.0
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
def write_view_script(path: Path, scale: float, normal: npt.ArrayLike | None, comm: MPI.Comm,
                      bodies: tuple[list[int], list[int]] = ([], [])) -> None:
    """Write the ParaView script ``path`` (``view.py`` of a result set) on rank 0 with the warp ``scale``, the
    camera of :func:`~fenics_coulomb.io.figures.contact_view` for ``normal`` and, for a mesh of several bodies,
    ``bodies`` = (every body's number, the numbers of those with contact nodes) (:func:`contact_bodies`)."""
    from fenics_coulomb.io.figures import contact_view

    if comm.rank != 0:
        return
    view, up = contact_view(normal)
    states = [(key, label) for key, label in CONTACT_STATES.items()]
    rgb = {str(key): list(colour) for key, colour in STATE_RGB.items()}
    Path(path).write_text(VIEW_SCRIPT.format(scale=float(scale), states=states, rgb=rgb,
                                             view=[float(c) for c in view], up=[float(c) for c in up],
                                             bodies=list(bodies[0]), slaves=list(bodies[1]),
                                             opacity=OBSTACLE_OPACITY))


def contact_bodies(model: ContactModel) -> tuple[list[int], list[int]]:
    """For a mesh of several bodies: (the body numbers 1, 2, … of the ``body`` field, those holding contact
    nodes), the same on every rank (collective); ([], []) for one body."""
    count = int(getattr(model, "num_bodies", 1) or 1)
    if count < 2:
        return [], []
    blocks = np.asarray(model.contact.blocks, dtype=np.int64)
    local: set[int] = {int(b) for b in np.asarray(model.body_of_block)[blocks] + 1} if blocks.size else set()
    slaves = sorted(set[int]().union(*model.comm.allgather(local)))
    return list(range(1, count + 1)), [int(b) for b in slaves]
