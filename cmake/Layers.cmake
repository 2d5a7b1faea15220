# microshadow_layer(NAME FOLDERS f... [SEES f...] [LINKS t...] [EXTRA src...] [KERNEL_LAYOUT] [UNITY])
#   A static library of every .cpp under host/<f>/ for each folder f, compiled against an include view
#   that holds only its own folders and the folders it SEES (list them transitively: a header of a seen
#   layer may include that layer's own dependencies). KERNEL_LAYOUT adds kernels/common, where the
#   host/kernel layout header lives. LINKS are the libraries it links (publicly). UNITY: compiled as a
#   unity build (below), for the layers whose files spend most of their time in shared headers. Every
#   layer sees and links the platform layer (ms_platform, host/platform).
set(MICROSHADOW_LAYERS "" CACHE INTERNAL "")

# Unity builds: most of a file's compile time in the upper layers is the headers it shares with its
# neighbours (the standard library, nlohmann-json, OpenEXR, opencl.hpp) and the templates they
# instantiate again in every file; a batch of files compiled as one translation unit pays for them once
# (the jobs layer: 21 s of one CPU for eight files that take 55 s apart). In such a layer, helpers in
# anonymous namespaces must have names unique within the layer. Batches of 8 keep two cores busy and a
# change's rebuild small. The lower layers (core, oracle, exact, io, ...) compile in seconds as they are.
option(MICROSHADOW_UNITY_BUILD "Compile each layer and the tests in batches of 8 files (unity build)" ON)
function(microshadow_unity target)
  set_target_properties(${target} PROPERTIES UNITY_BUILD ${MICROSHADOW_UNITY_BUILD} UNITY_BUILD_BATCH_SIZE 8)
  if(MICROSHADOW_UNITY_BUILD AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    # gcc takes a .cpp included by the batch file for a header and warns when a type of its anonymous
    # namespace appears in a template or lambda there (-Wsubobject-linkage); in a .cpp that is no risk.
    target_compile_options(${target} PRIVATE -Wno-subobject-linkage)
  endif()
endfunction()

function(microshadow_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra)
  if(MICROSHADOW_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

function(microshadow_layer name)
  cmake_parse_arguments(L "KERNEL_LAYOUT;UNITY" "" "FOLDERS;SEES;LINKS;EXTRA" ${ARGN})
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
  # Every layer may use the platform layer (host/platform: the operating system's services), which
  # itself sees nothing of ours.
  if(NOT name STREQUAL "ms_platform")
    file(CREATE_LINK ${PROJECT_SOURCE_DIR}/host/platform ${view}/platform SYMBOLIC)
    list(APPEND L_LINKS ms_platform)
  endif()
  target_include_directories(${name} PRIVATE ${view})
  if(L_KERNEL_LAYOUT)
    target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/kernels/common)
  endif()
  target_compile_definitions(${name} PUBLIC
    CL_HPP_TARGET_OPENCL_VERSION=120 CL_HPP_MINIMUM_OPENCL_VERSION=120 CL_TARGET_OPENCL_VERSION=120
    CL_HPP_ENABLE_EXCEPTIONS MICROSHADOW_VERSION="${PROJECT_VERSION}")
  target_link_libraries(${name} PUBLIC ${L_LINKS} tomlplusplus::tomlplusplus nlohmann_json::nlohmann_json Threads::Threads)
  microshadow_warnings(${name})
  if(L_UNITY)
    microshadow_unity(${name})
  endif()
  set(MICROSHADOW_LAYERS ${MICROSHADOW_LAYERS} ${name} CACHE INTERNAL "")
endfunction()
