# Shaders live in .glsl files (readable, diffable, editor-highlighted) and are compiled into the
# library as raw string literals, so nothing is read at run time:
#   vellum_embed_glsl(<target> <namespace> <file.glsl>...)
# generates <target>_glsl.hpp/.cpp (in the build tree, on the target's include path) with one
# `extern const char* const k<Name>` per file in <namespace>: ray_common.glsl -> kRayCommon,
# raycast.frag.glsl -> kRaycastFrag. They are regenerated when a .glsl file changes.
# Run with -P, this file is the generator itself (BASE, NAMESPACE, FILES separated by '|').

if(CMAKE_SCRIPT_MODE_FILE)
  string(REPLACE "|" ";" files "${FILES}")
  get_filename_component(header "${BASE}.hpp" NAME)
  set(hpp "// Generated from .glsl files by modules/render/embed_glsl.cmake: edit those.\n#pragma once\n\nnamespace ${NAMESPACE} {\n")
  set(cpp "// Generated from .glsl files by modules/render/embed_glsl.cmake: edit those.\n#include \"${header}\"\n\nnamespace ${NAMESPACE} {\n")
  foreach(f IN LISTS files)
    get_filename_component(name "${f}" NAME)
    string(REGEX REPLACE "\\.glsl$" "" stem "${name}")
    string(REGEX REPLACE "[._-]" ";" parts "${stem}")
    set(id k)
    foreach(p IN LISTS parts)
      string(SUBSTRING "${p}" 0 1 first)
      string(TOUPPER "${first}" first)
      string(SUBSTRING "${p}" 1 -1 rest)
      string(APPEND id "${first}${rest}")
    endforeach()
    file(READ "${f}" text)
    string(FIND "${text}" ")GLSL\"" clash)
    if(NOT clash EQUAL -1)
      message(FATAL_ERROR "${f}: contains the raw-string delimiter )GLSL\"")
    endif()
    string(APPEND hpp "extern const char* const ${id};  ///< ${name}\n")
    string(APPEND cpp "extern const char* const ${id} = R\"GLSL(${text})GLSL\";\n")
  endforeach()
  string(APPEND hpp "\n}  // namespace ${NAMESPACE}\n")
  string(APPEND cpp "\n}  // namespace ${NAMESPACE}\n")
  # The header only changes with the file list: kept as it is, its includers are not rebuilt.
  file(CONFIGURE OUTPUT "${BASE}.hpp" CONTENT "${hpp}" @ONLY)
  file(WRITE "${BASE}.cpp" "${cpp}")
  return()
endif()

include_guard(GLOBAL)

function(vellum_embed_glsl target namespace)
  set(base ${CMAKE_CURRENT_BINARY_DIR}/generated/${target}_glsl)
  list(TRANSFORM ARGN PREPEND ${CMAKE_CURRENT_SOURCE_DIR}/ OUTPUT_VARIABLE files)
  list(JOIN files "|" joined)
  add_custom_command(OUTPUT ${base}.cpp ${base}.hpp
    COMMAND ${CMAKE_COMMAND} -DBASE=${base} -DNAMESPACE=${namespace} -DFILES=${joined}
            -P ${CMAKE_CURRENT_FUNCTION_LIST_FILE}
    DEPENDS ${files} ${CMAKE_CURRENT_FUNCTION_LIST_FILE}
    COMMENT "Embedding the GLSL of ${target}" VERBATIM)
  target_sources(${target} PRIVATE ${base}.cpp ${base}.hpp)
  target_include_directories(${target} PRIVATE ${CMAKE_CURRENT_BINARY_DIR}/generated)
endfunction()
