// The specular kernel and the row kernels built for baseline (flags in native/CMakeLists.txt).
#define IBLBAKE_KERNEL_NAME sums_baseline
#include "specular_kernel_impl.h"
#define IBLBAKE_SH9_ROW_NAME sh9_row_baseline
#define IBLBAKE_MIRROR_ROW_NAME mirror_row_baseline
#include "row_kernels_impl.h"
