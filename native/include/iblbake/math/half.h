// IEEE binary16 from float, rounded to nearest even (as Imath's half(float)):
// by the CPU's F16C instructions where it has them (chosen at run time; the
// library is built for baseline x86-64), else in software.
#pragma once
#include <cstddef>
#include <cstdint>

namespace iblbake {

uint16_t float_to_half(float v);
void floats_to_half(const float* in, uint16_t* out, size_t n);

// n binary16 values (bytes, native order) as floats, exactly (F16C where
// the CPU has it, else Imath's table; a NaN stays a NaN, its payload
// aside). `in` may lie in out's own storage at or after byte 2 n (the upper
// half of n floats): value k is read before float k is written, and no
// float written reaches a value not yet read.
void halves_to_floats(const void* in, float* out, size_t n);
namespace detail {
void halves_to_floats_software(const void* in, float* out, size_t n);  // the path without F16C (tests)
}

}  // namespace iblbake
