# Target: macOS 11+ on Intel (macosx_11_0_x86_64 wheels). See macos.cmake.
set(QUATCURVE_MACOS_ARCH x86_64)
set(QUATCURVE_MACOS_ARCH_ZIG x86_64)
include(${CMAKE_CURRENT_LIST_DIR}/macos.cmake)
