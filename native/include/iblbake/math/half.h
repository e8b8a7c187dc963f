// IEEE binary16 from float, rounded to nearest even (as Imath's half(float)):
// by the CPU's F16C instructions where it has them (chosen at run time; the
// library is built for baseline x86-64), else in software.
#pragma once
#include <cstddef>
#include <cstdint>

namespace iblbake {

uint16_t float_to_half(float v);
void floats_to_half(const float* in, uint16_t* out, size_t n);

}  // namespace iblbake
