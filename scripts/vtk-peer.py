#!/usr/bin/env python3
"""The peer a user would pick instead of irt for isosurfaces (docs/volumes.md): VTK from PyPI
(`pip install vtk`), extracting the surface of a new isovalue (vtkFlyingEdges3D, VTK's fastest
extractor, and the classic vtkMarchingCubes) and drawing it offscreen at 512x512. Prints a
markdown table: what a new isovalue costs (extract + the first frame that shows it) and the frame
after. Run under a display (Xvfb) if VTK's wheel has no EGL or OSMesa on this machine:

    Xvfb :81 & DISPLAY=:81 python3 scripts/vtk-peer.py tests/data/volumes/mni152_t1.nii.gz 40 80 150
"""
import statistics
import sys
import time

import vtk


def reader_for(path):
    if path.endswith((".nii", ".nii.gz")):
        r = vtk.vtkNIFTIImageReader()
    elif path.endswith(".nrrd"):
        r = vtk.vtkNrrdReader()
    elif path.endswith(".vti"):
        r = vtk.vtkXMLImageDataReader()
    else:
        sys.exit(f"{path}: give a .nii(.gz), .nrrd or .vti file")
    r.SetFileName(path)
    return r


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    path, isos = sys.argv[1], [float(x) for x in sys.argv[2:]]
    t = time.perf_counter()
    reader = reader_for(path)
    reader.Update()
    load = time.perf_counter() - t
    dims = reader.GetOutput().GetDimensions()
    print(f"VTK {vtk.vtkVersion.GetVTKVersion()}: {path} {dims[0]}x{dims[1]}x{dims[2]}, loaded in {load:.2f} s")
    for name, cls in (("vtkFlyingEdges3D", vtk.vtkFlyingEdges3D), ("vtkMarchingCubes", vtk.vtkMarchingCubes)):
        extract = cls()
        extract.SetInputConnection(reader.GetOutputPort())
        extract.ComputeNormalsOn()
        mapper = vtk.vtkPolyDataMapper()
        mapper.SetInputConnection(extract.GetOutputPort())
        mapper.ScalarVisibilityOff()
        actor = vtk.vtkActor()
        actor.SetMapper(mapper)
        ren = vtk.vtkRenderer()
        ren.AddActor(actor)
        win = vtk.vtkRenderWindow()
        win.SetOffScreenRendering(1)
        win.SetSize(512, 512)
        win.AddRenderer(ren)
        win.Render()
        gl = [l.split(":", 1)[1].strip() for l in win.ReportCapabilities().splitlines() if "renderer string" in l]
        print(f"\n{name}, drawn by {win.GetClassName()} on {gl[0] if gl else 'an unnamed OpenGL renderer'}")
        print("\n| isovalue | triangles | extract s | first frame s | frame ms |")
        print("| --- | --- | --- | --- | --- |")
        for i, iso in enumerate(isos):
            extract.SetValue(0, iso)
            t = time.perf_counter()
            extract.Update()
            ex = time.perf_counter() - t
            if i == 0:
                ren.ResetCamera()
            t = time.perf_counter()
            win.Render()
            first = time.perf_counter() - t
            frames = []
            for _ in range(5):
                ren.GetActiveCamera().Azimuth(0.5)
                t = time.perf_counter()
                win.Render()
                frames.append(time.perf_counter() - t)
            tris = extract.GetOutput().GetNumberOfPolys()
            print(f"| {iso:g} | {tris} | {ex:.3f} | {first:.3f} | {1e3 * statistics.median(frames):.1f} |")


if __name__ == "__main__":
    main()
