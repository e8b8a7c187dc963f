// Cubic spline interpolation on uniform nodes 0, 1, ..., n-1 with
// not-a-knot ends (the first two and the last two cubic pieces are one
// cubic each), so the error is O(h^4) up to the ends, not O(h^2) as with
// natural ends. Pure functions, no I/O.
#pragma once
#include <vector>

namespace iblbake {

// The n x n matrix S (row-major) with m = S y: the second derivatives of the
// not-a-knot spline through values y at the nodes. n >= 4.
std::vector<double> not_a_knot_matrix(int n);

// The spline with values y and second derivatives m (n of each) at t in
// [0, n - 1] (clamped).
double spline_at(const double* y, const double* m, int n, double t);

}  // namespace iblbake
