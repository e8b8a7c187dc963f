// The specular kernel and the row kernels built for avx512 (flags in native/CMakeLists.txt).
#define IBLBAKE_KERNEL_NAME sums_avx512
#include "specular_kernel_impl.h"
#define IBLBAKE_ISA_SUFFIX avx512
#include "row_kernels_impl.h"
