# Shared by macos-arm64.cmake and macos-x64.cmake: a macOS 11+ module cross-compiled by zig's clang
# (zig brings macOS's libc headers and libSystem's stubs; libc++ linked statically, so the module loads
# only libSystem). build_scripts/package.sh sets QUATCURVE_ZIG (see zig.cmake) and
#   QUATCURVE_PYTHON_SDK    CPython's headers (build_scripts/cross_inputs.py macos-sdk 3.XX: include/)
# and SETUPTOOLS_EXT_SUFFIX=.cpython-3XX-darwin.so, _PYTHON_HOST_PLATFORM=macosx-11.0-<arch>. No macOS
# machine runs these modules here: they are built and checked by their structure (tests/package/check_macos.py).
include(${CMAKE_CURRENT_LIST_DIR}/zig.cmake)
set(CMAKE_SYSTEM_NAME Darwin)
set(CMAKE_SYSTEM_VERSION 20.0)  # Darwin 20: macOS 11
set(CMAKE_SYSTEM_PROCESSOR ${QUATCURVE_MACOS_ARCH})
set(CMAKE_OSX_SYSROOT "" CACHE PATH "zig's own macOS headers and stubs; no SDK")
quatcurve_zig_compiler(${QUATCURVE_MACOS_ARCH_ZIG}-macos.11.0)
# No strip after the link (pybind11 strips a Release module when CMAKE_STRIP names a program): the build
# machine's strip does not know Mach-O, and stripping would break the ad-hoc signature zig's linker writes.
set(CMAKE_STRIP "" CACHE FILEPATH "no strip: it would break the code signature")

# FindPython, without an interpreter of the target: the headers alone (a module resolves the C API at load).
if(NOT EXISTS "${QUATCURVE_PYTHON_SDK}/include/Python.h")
  message(FATAL_ERROR "QUATCURVE_PYTHON_SDK (${QUATCURVE_PYTHON_SDK}) holds no include/Python.h: "
                      "run build_scripts/cross_inputs.py macos-sdk 3.XX")
endif()
set(Python_INCLUDE_DIR "${QUATCURVE_PYTHON_SDK}/include" CACHE PATH "CPython's headers")
