// The cube layouts SPEC section 2 allows besides its horizontal cross: a
// vertical cross, six face images, a lat-long per cube. Each is produced in
// bands of rows as RGBA floats (alpha 1 on faces, 0 on unused cells), the way
// the image writers take them. No I/O.
#pragma once
#include <string>

#include "iblbake/ibl/cube_sampling.h"
#include "iblbake/image/image.h"

namespace iblbake {

enum class CubeLayout { HCross, VCross, Faces, LatLong };
const char* layout_name(CubeLayout l);
CubeLayout layout_from_name(const std::string& name);  // throws std::invalid_argument
extern const char* const kFaceSuffixes[6];                // "px", "nx", "py", "ny", "pz", "nz"

// Vertical cross, 3N wide and 4N high:
//     .   +Y  .
//     -X  +Z  +X
//     .   -Y  .
//     .   -Z  .
// with the -Z face turned 180 degrees (so that it joins -Y's bottom edge).
void vcross_rgba_rows(const Cubemap& cube, int y0, int rows, float* out);
// Face `face` alone (N x N).
void face_rgba_rows(const Cubemap& cube, int face, int y0, int rows, float* out);
// A lat-long of width w and height h in SPEC section 1's orientation, each
// texel the seamless bilinear cube lookup at its centre's direction.
void latlong_rgba_rows(const BorderedCube& cube, int w, int h, int y0, int rows, float* out);

}  // namespace iblbake
