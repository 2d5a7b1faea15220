# Portability check, run at configure time: only the platform layer (host/platform/) includes the
# operating system's own headers, POSIX (unistd.h, sys/*.h, fcntl.h, signal.h, spawn.h, dlfcn.h, ...)
# or Win32 (windows.h, io.h, ...); every other file of the library, the program and the public headers
# uses the standard library and ms::platform. A new include of such a header elsewhere stops the
# configure step with the file and the line, as cmake/Layers.cmake's include views stop a layer that
# reaches into another.
set(MICROSHADOW_SYSTEM_HEADERS
    "unistd\\.h" "sys/[a-z_/]+\\.h" "fcntl\\.h" "signal\\.h" "spawn\\.h" "dlfcn\\.h" "dirent\\.h" "pthread\\.h"
    "poll\\.h" "termios\\.h" "pwd\\.h" "grp\\.h" "netdb\\.h" "syslog\\.h" "sched\\.h" "semaphore\\.h" "libgen\\.h"
    "windows\\.h" "io\\.h" "process\\.h" "direct\\.h" "winsock2?\\.h")
list(JOIN MICROSHADOW_SYSTEM_HEADERS "|" _ms_system_header_alternatives)
set(_ms_system_include "#[ \t]*include[ \t]*<(${_ms_system_header_alternatives})>")

function(microshadow_check_platform_headers)
  file(GLOB_RECURSE checked CONFIGURE_DEPENDS
       ${PROJECT_SOURCE_DIR}/host/*.cpp ${PROJECT_SOURCE_DIR}/host/*.hpp
       ${PROJECT_SOURCE_DIR}/include/*.hpp ${PROJECT_SOURCE_DIR}/include/*.h)
  list(FILTER checked EXCLUDE REGEX "/host/platform/")
  set(found "")
  foreach(file IN LISTS checked)
    file(STRINGS ${file} lines REGEX "${_ms_system_include}")
    foreach(line IN LISTS lines)
      file(RELATIVE_PATH rel ${PROJECT_SOURCE_DIR} ${file})
      string(STRIP "${line}" line)
      string(APPEND found "\n  ${rel}: ${line}")
    endforeach()
  endforeach()
  if(found)
    message(FATAL_ERROR "System headers outside host/platform/ (use ms::platform, host/platform/*.hpp, or the "
                        "standard library instead):${found}")
  endif()
endfunction()
microshadow_check_platform_headers()
