# Shared by the toolchain files beside this one: zig's clang as the C++ compiler for one target triple.
# The settings come as CMake variables or, the first time, from the environment (pip wheel . passes the
# environment to scikit-build-core, which runs CMake); they are kept in the cache and handed to
# CMake's own test builds (try_compile).
foreach(_quatcurve_var QUATCURVE_ZIG QUATCURVE_PYTHON_SDK)
  if(NOT ${_quatcurve_var} AND DEFINED ENV{${_quatcurve_var}})
    set(${_quatcurve_var} "$ENV{${_quatcurve_var}}" CACHE PATH "set by build_scripts/package.sh")
  endif()
endforeach()
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES QUATCURVE_ZIG QUATCURVE_PYTHON_SDK)
if(NOT QUATCURVE_ZIG OR NOT EXISTS "${QUATCURVE_ZIG}")
  message(FATAL_ERROR "QUATCURVE_ZIG (${QUATCURVE_ZIG}) is not the zig executable: set it to the one of PyPI's "
                      "ziglang (build_scripts/package.sh does)")
endif()

# quatcurve_zig_compiler(TRIPLE): `zig c++ -target TRIPLE` compiles and links. zig searches only its own
# headers for the target's C library, never /usr/include (GLM comes from package.sh's glm_DIR).
macro(quatcurve_zig_compiler triple)
  set(CMAKE_CXX_COMPILER "${QUATCURVE_ZIG}")
  set(CMAKE_CXX_COMPILER_ARG1 "c++ -target ${triple}")
endmacro()

# The module's file name: scikit-build-core and pybind11 take it from SETUPTOOLS_EXT_SUFFIX (set by
# package.sh, e.g. .cp311-win_amd64.pyd); FindPython, without the target's interpreter, is told the same.
if(DEFINED ENV{SETUPTOOLS_EXT_SUFFIX})
  string(REGEX REPLACE "^\\.(.*)\\.[a-z]+$" "\\1" _quatcurve_soabi "$ENV{SETUPTOOLS_EXT_SUFFIX}")
  set(Python_SOABI "${_quatcurve_soabi}" CACHE STRING "the target's extension module ABI tag")
endif()
set(CMAKE_USER_MAKE_RULES_OVERRIDE_CXX "${CMAKE_CURRENT_LIST_DIR}/zig-rules.cmake")
