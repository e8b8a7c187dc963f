# The wheels' modules (scripts/package.sh runs this inside a Debian 11
# chroot, glibc 2.31): one iblbake_core per Python in IBLBAKE_WHEEL_PYTHONS,
# built from the same iblbake_lib, each into wheel/cpXY/.
#
# Self-contained: every library but the C runtime (libc, libm, the dynamic
# loader) is linked in statically, C++ runtime included, and nothing but
# PyInit_iblbake_core is exported (python/wheel_exports.map), so a process
# that already holds another OpenEXR, Imath, TBB or libstdc++ (Blender,
# OpenImageIO's Python module) never binds our calls to its copies nor its
# calls to ours: --exclude-libs makes the archives' symbols local, and the
# version script hides the rest.
#
# Python's headers come from Debian's libpython3.X-dev packages, unpacked (not
# installed) under IBLBAKE_WHEEL_PYTHON_ROOT; pybind11 is header-only and
# needs no interpreter (PYBIND11_NOPYTHON).
set(PYBIND11_NOPYTHON ON)
find_package(pybind11 CONFIG REQUIRED)
if(NOT CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$")
  message(FATAL_ERROR "wheel modules: only x86_64 (linux-x64) is set up")
endif()
set(_multiarch x86_64-linux-gnu)
option(IBLBAKE_WHEEL_STRIP "Strip the wheel modules" ON)
foreach(_py IN LISTS IBLBAKE_WHEEL_PYTHONS)
  string(REPLACE "." "" _tag "${_py}")
  set(_inc ${IBLBAKE_WHEEL_PYTHON_ROOT}/usr/include/python${_py})
  set(_inc_arch ${IBLBAKE_WHEEL_PYTHON_ROOT}/usr/include/${_multiarch}/python${_py})
  if(NOT EXISTS ${_inc}/Python.h OR NOT EXISTS ${_inc_arch}/pyconfig.h)
    message(FATAL_ERROR "wheel modules: no Python ${_py} headers under ${IBLBAKE_WHEEL_PYTHON_ROOT} "
                        "(${_inc}/Python.h, ${_inc_arch}/pyconfig.h)")
  endif()
  set(_target iblbake_core_cp${_tag})
  add_library(${_target} MODULE python/module.cpp python/arrays.cpp python/bind_bake.cpp python/bind_geometry.cpp
    python/bind_batch.cpp)
  target_include_directories(${_target} SYSTEM PRIVATE ${_inc} ${_inc_arch})
  target_link_libraries(${_target} PRIVATE iblbake_lib pybind11::headers)
  target_compile_definitions(${_target} PRIVATE IBLBAKE_VERSION="${PROJECT_VERSION}")
  iblbake_warnings(${_target})
  set_target_properties(${_target} PROPERTIES
    PREFIX "" OUTPUT_NAME iblbake_core SUFFIX ".cpython-${_tag}-${_multiarch}.so"
    LIBRARY_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/wheel/cp${_tag}
    CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
  target_link_options(${_target} PRIVATE
    -static-libstdc++ -static-libgcc
    -Wl,--exclude-libs,ALL
    -Wl,--version-script=${CMAKE_CURRENT_SOURCE_DIR}/python/wheel_exports.map
    -Wl,--gc-sections -Wl,--as-needed -Wl,-z,relro,-z,now)
  # Stripped after the link, not by it: Debian 11's ld (binutils 2.35) with
  # -s wrote a module that crashed on its first call through the PLT (the
  # target_clones IFUNCs, which make the file's OS ABI GNU/Linux, came out
  # SYSV); strip(1) on the linked file leaves the relocations alone.
  if(IBLBAKE_WHEEL_STRIP)
    add_custom_command(TARGET ${_target} POST_BUILD COMMAND ${CMAKE_STRIP} --strip-all $<TARGET_FILE:${_target}> VERBATIM)
  endif()
endforeach()
