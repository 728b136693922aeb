# Target: macOS 11+ on Apple silicon (macosx_11_0_arm64 wheels). See macos.cmake.
set(QUATCURVE_MACOS_ARCH arm64)
set(QUATCURVE_MACOS_ARCH_ZIG aarch64)
include(${CMAKE_CURRENT_LIST_DIR}/macos.cmake)
