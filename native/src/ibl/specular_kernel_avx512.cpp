// The specular kernel and the row kernels built for avx512 (flags in native/CMakeLists.txt).
#define IBLBAKE_KERNEL_NAME sums_avx512
#include "specular_kernel_impl.h"
#define IBLBAKE_SH9_ROW_NAME sh9_row_avx512
#define IBLBAKE_MIRROR_ROW_NAME mirror_row_avx512
#include "row_kernels_impl.h"
