# Cross-compiling for 64-bit Windows with Debian's MinGW-w64 (g++-mingw-w64-x86-64-posix), used by
# scripts/build-windows.sh for the dependencies and the project alike. The -posix compilers use the
# winpthreads threading model, which std::thread and std::mutex need.
set(CMAKE_SYSTEM_NAME Windows)
set(CMAKE_SYSTEM_PROCESSOR x86_64)
set(MINGW_TRIPLE x86_64-w64-mingw32)
set(CMAKE_C_COMPILER ${MINGW_TRIPLE}-gcc-posix)
set(CMAKE_CXX_COMPILER ${MINGW_TRIPLE}-g++-posix)
set(CMAKE_RC_COMPILER ${MINGW_TRIPLE}-windres)
# Libraries and packages come from the MinGW sysroot and the prefix the dependencies were installed into
# (CMAKE_PREFIX_PATH, given on the command line); programs run on the build machine come from the host.
set(CMAKE_FIND_ROOT_PATH /usr/${MINGW_TRIPLE} ${CMAKE_PREFIX_PATH})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
# One self-contained .exe: the C++ runtime, winpthreads and libgcc linked in, so the program runs without
# MinGW's DLLs beside it (on Windows and under Wine alike).
set(CMAKE_EXE_LINKER_FLAGS_INIT "-static -static-libgcc -static-libstdc++")
# Test programs run through Wine when CMake or ctest needs to execute one (gtest_discover_tests).
find_program(MINGW_WINE64 NAMES wine64 wine)
if(MINGW_WINE64)
  set(CMAKE_CROSSCOMPILING_EMULATOR ${MINGW_WINE64})
endif()
