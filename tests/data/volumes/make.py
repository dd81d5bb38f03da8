"""Writes the small volumes of tests/it/volumes.rs: one distance field (the distance to the
point (0.25, -0.5, 0.75), so its level set 2 is a sphere of radius 2) on a 17x15x13 grid of
spacing (0.5, 0.5, 0.6) from (-4, -3.5, -3.6), in each format and encoding irt reads.
Run: python3 make.py (numpy and nibabel; nibabel writes the NIfTI files as the field does)."""
import base64, gzip, struct
import numpy as np
import nibabel as nb

NX, NY, NZ = 17, 15, 13
SP = (0.5, 0.5, 0.6)
ORIGIN = (-4.0, -3.5, -3.6)
CENTRE = (0.25, -0.5, 0.75)

i, j, k = np.meshgrid(np.arange(NX), np.arange(NY), np.arange(NZ), indexing="ij")
x, y, z = (ORIGIN[a] + (i, j, k)[a] * SP[a] for a in range(3))
field = np.sqrt((x - CENTRE[0]) ** 2 + (y - CENTRE[1]) ** 2 + (z - CENTRE[2]) ** 2).astype(np.float32)
# x fastest: Fortran order of the (x, y, z) array.
flat = field.ravel(order="F")

def header(encoding, extra=""):
    return (
        "NRRD0004\n# irt test volume: distance to (0.25, -0.5, 0.75)\n"
        f"type: float\ndimension: 3\nsizes: {NX} {NY} {NZ}\nendian: little\n"
        f"encoding: {encoding}\nspace: right-anterior-superior\n"
        f"space directions: ({SP[0]},0,0) (0,{SP[1]},0) (0,0,{SP[2]})\n"
        f"space origin: ({ORIGIN[0]},{ORIGIN[1]},{ORIGIN[2]})\n{extra}"
    )

open("sphere_raw.nrrd", "wb").write((header("raw") + "\n").encode() + flat.astype("<f4").tobytes())
open("sphere_ascii.nrrd", "w").write(header("ascii") + "\n" + " ".join(f"{v:.9g}" for v in flat) + "\n")
open("sphere_gzip.nhdr", "w").write(header("gzip", "data file: sphere_gzip.raw.gz\n"))
open("sphere_gzip.raw.gz", "wb").write(gzip.compress(flat.astype("<f4").tobytes(), mtime=0))
# Big-endian 16-bit, the field times 1000, spacings instead of directions.
u16 = np.round(flat * 1000).astype(">u2")
h16 = (f"NRRD0005\ntype: unsigned short\ndimension: 3\nsizes: {NX} {NY} {NZ}\nendian: big\n"
       f"encoding: raw\nspacings: {SP[0]} {SP[1]} {SP[2]}\n"
       f"space origin: ({ORIGIN[0]},{ORIGIN[1]},{ORIGIN[2]})\n\n")
open("sphere_u16be.nrrd", "wb").write(h16.encode() + u16.tobytes())

# NIfTI: the sform runs x backwards (radiological order), so the file holds x reversed.
affine = np.diag([-SP[0], SP[1], SP[2], 1.0])
affine[:3, 3] = (ORIGIN[0] + (NX - 1) * SP[0], ORIGIN[1], ORIGIN[2])
img = nb.Nifti1Image(field[::-1, :, :].copy(), affine)
img.set_sform(affine, code=1)
img.set_qform(None, code=0)
nb.save(img, "sphere_flipped.nii.gz")
# The same field as int16: nibabel picks a scl_slope and scl_inter that fit the field into
# int16, and the reader must apply them. Placed by the qform alone.
aff = np.diag([*SP, 1.0])
aff[:3, 3] = ORIGIN
img16 = nb.Nifti1Image(field, aff)
img16.set_data_dtype(np.int16)
img16.set_qform(aff, code=1)
img16.set_sform(None, code=0)
nb.save(img16, "sphere_int16_qform.nii")

def vti(fmt):
    if fmt == "ascii":
        data = " ".join(f"{v:.9g}" for v in flat)
    else:
        raw = flat.astype("<f4").tobytes()
        data = base64.b64encode(struct.pack("<I", len(raw)) + raw).decode()
    o = ORIGIN
    return f"""<?xml version="1.0"?>
<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" header_type="UInt32">
  <ImageData WholeExtent="0 {NX-1} 0 {NY-1} 0 {NZ-1}" Origin="{o[0]} {o[1]} {o[2]}" Spacing="{SP[0]} {SP[1]} {SP[2]}">
    <Piece Extent="0 {NX-1} 0 {NY-1} 0 {NZ-1}">
      <PointData Scalars="distance">
        <DataArray type="Float32" Name="distance" format="{fmt}">
{data}
        </DataArray>
      </PointData>
      <CellData>
      </CellData>
    </Piece>
  </ImageData>
</VTKFile>
"""
open("sphere_ascii.vti", "w").write(vti("ascii"))
open("sphere_binary.vti", "w").write(vti("binary"))
