// The specular kernel built for avx512 (flags in native/CMakeLists.txt).
#define IBLBAKE_KERNEL_NAME sums_avx512
#include "specular_kernel_impl.h"
