"""Run by pvpython/pvbatch (tests/io/test_paraview.py): open an XDMF file as a ParaView user does and report what
ParaView shows, as one JSON line on stdout.

Usage: ``pvpython --force-offscreen-rendering paraview_probe.py FILE.xdmf READER [SCREENSHOT.png]`` where READER
is ``default`` (``paraview.simple.OpenDataFile``: the reader ParaView picks for .xdmf) or a proxy name
(``XDMFReader``, ``Xdmf3ReaderS``, ``Xdmf3ReaderT``). With a screenshot path the default pipeline of docs/outputs.md
is applied: Warp By Vector (displacement), colour by contact_state, render.
"""

import json
import sys

import paraview.simple as ps
from paraview import servermanager


def describe(dataset):  # a vtkDataSet or a composite
    blocks = []
    if dataset.IsA("vtkCompositeDataSet"):
        it = dataset.NewIterator()
        it.InitTraversal()
        while not it.IsDoneWithTraversal():
            blocks.append(it.GetCurrentDataObject())
            it.GoToNextItem()
    else:
        blocks.append(dataset)
    out = []
    for block in blocks:
        pd = block.GetPointData()
        arrays = {}
        for i in range(pd.GetNumberOfArrays()):
            a = pd.GetArray(i)
            comps = a.GetNumberOfComponents()
            arrays[a.GetName()] = {
                "type": a.GetDataTypeAsString(),
                "components": comps,
                "range": list(a.GetRange(-1 if comps > 1 else 0)),
                "component_ranges": [list(a.GetRange(c)) for c in range(comps)],
                "tuples": a.GetNumberOfTuples(),
            }
        pts = block.GetPoints()
        out.append({"class": block.GetClassName(), "points": block.GetNumberOfPoints(),
                    "cells": block.GetNumberOfCells(), "point_type": pts.GetData().GetDataTypeAsString()
                    if pts is not None else None, "bounds": list(block.GetBounds()), "arrays": arrays})
    return out


def main(path, reader, screenshot=None):
    if reader == "default":
        source = ps.OpenDataFile(path)
    else:
        source = getattr(ps, reader)(**{"FileName" if reader.startswith("Xdmf3") else "FileNames": [path]})
    source.UpdatePipeline()
    report = {"reader": source.GetXMLName(), "blocks": describe(servermanager.Fetch(source))}
    if screenshot:
        warp = ps.WarpByVector(Input=source)  # the default vector array, as a user's Apply takes it
        warp.UpdatePipeline()
        report["warp_vectors"] = list(warp.Vectors)
        report["warped"] = describe(servermanager.Fetch(warp))
        view = ps.GetActiveViewOrCreate("RenderView")
        view.ViewSize = [640, 400]
        view.OrientationAxesVisibility = 0
        display = ps.Show(warp, view)
        ps.ColorBy(display, ("POINTS", "contact_state"))
        lut = ps.GetColorTransferFunction("contact_state")
        report["colour_array"] = display.ColorArrayName[1]
        report["lut_range"] = [lut.RGBPoints[0], lut.RGBPoints[-4]] if lut.RGBPoints else []
        view.ResetCamera()
        view.CameraPosition = [1.0 + 2.0, 0.5 - 4.0, 0.5 - 3.0]
        view.CameraFocalPoint = [1.0, 0.5, 0.3]
        view.CameraViewUp = [0.0, 0.0, 1.0]
        view.ResetCamera()
        ps.Render(view)
        ps.SaveScreenshot(screenshot, view, ImageResolution=[640, 400])
    print("PROBE " + json.dumps(report), flush=True)


if __name__ == "__main__":
    main(*sys.argv[1:])
