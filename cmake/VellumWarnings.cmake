# Warnings and sanitizers for Vellum's own targets (never for third-party headers, which are
# included as SYSTEM by their imported targets).
add_library(vellum_warnings INTERFACE)
target_compile_options(vellum_warnings INTERFACE -Wall -Wextra -Wpedantic -Wno-psabi)
if(VELLUM_FUZZ)
  # Coverage instrumentation for every Vellum target; the harnesses link libFuzzer's main.
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "VELLUM_FUZZ needs clang (CC=clang-14 CXX=clang++-14)")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer -g)
  add_link_options(-fsanitize=address,undefined)
elseif(VELLUM_SANITIZE)
  # -O1 (AddressSanitizer's recommended level) after the build type's flags: the numeric
  # tests (maps, distance fields, segmentation) run at a useful speed; asserts stay on in Debug.
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined -O1 -g)
  add_link_options(-fsanitize=address,undefined)
endif()

# vellum_module(NAME SOURCES ... DEPS ...): one library target per folder, alias vellum::NAME.
function(vellum_module name)
  cmake_parse_arguments(VM "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  if(VM_SOURCES)
    add_library(vellum_${name} STATIC ${VM_SOURCES})
    target_include_directories(vellum_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
    target_link_libraries(vellum_${name} PUBLIC ${VM_PUBLIC_DEPS} PRIVATE ${VM_PRIVATE_DEPS} vellum_warnings)
  else()
    add_library(vellum_${name} INTERFACE)
    target_include_directories(vellum_${name} INTERFACE ${CMAKE_CURRENT_SOURCE_DIR}/include)
    target_link_libraries(vellum_${name} INTERFACE ${VM_PUBLIC_DEPS})
  endif()
  add_library(vellum::${name} ALIAS vellum_${name})
endfunction()
