# microshadow_layer(NAME FOLDERS f... [SEES f...] [LINKS t...] [EXTRA src...] [KERNEL_LAYOUT])
#   A static library of every .cpp under host/<f>/ for each folder f, compiled against an include view
#   that holds only its own folders and the folders it SEES (list them transitively: a header of a seen
#   layer may include that layer's own dependencies). KERNEL_LAYOUT adds kernels/common, where the
#   host/kernel layout header lives. LINKS are the libraries it links (publicly).
set(MICROSHADOW_LAYERS "" CACHE INTERNAL "")

function(microshadow_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra)
  if(MICROSHADOW_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

function(microshadow_layer name)
  cmake_parse_arguments(L "KERNEL_LAYOUT" "" "FOLDERS;SEES;LINKS;EXTRA" ${ARGN})
  set(sources "")
  foreach(folder IN LISTS L_FOLDERS)
    file(GLOB_RECURSE found CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/host/${folder}/*.cpp)
    list(APPEND sources ${found})
  endforeach()
  add_library(${name} STATIC ${sources} ${L_EXTRA})
  set(view ${PROJECT_BINARY_DIR}/layers/${name})
  file(REMOVE_RECURSE ${view})
  file(MAKE_DIRECTORY ${view})
  foreach(folder IN LISTS L_FOLDERS L_SEES)
    file(CREATE_LINK ${PROJECT_SOURCE_DIR}/host/${folder} ${view}/${folder} SYMBOLIC)
  endforeach()
  target_include_directories(${name} PRIVATE ${view})
  if(L_KERNEL_LAYOUT)
    target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/kernels/common)
  endif()
  target_compile_definitions(${name} PUBLIC
    CL_HPP_TARGET_OPENCL_VERSION=120 CL_HPP_MINIMUM_OPENCL_VERSION=120 CL_TARGET_OPENCL_VERSION=120
    CL_HPP_ENABLE_EXCEPTIONS MICROSHADOW_VERSION="${PROJECT_VERSION}")
  target_link_libraries(${name} PUBLIC ${L_LINKS} tomlplusplus::tomlplusplus nlohmann_json::nlohmann_json Threads::Threads)
  microshadow_warnings(${name})
  set(MICROSHADOW_LAYERS ${MICROSHADOW_LAYERS} ${name} CACHE INTERNAL "")
endfunction()
