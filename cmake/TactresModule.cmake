# tactres_library(NAME
#   SOURCES src/a.cpp ...      the library's sources, listed (no globbing)
#   TESTS src/a_test.cpp ...   doctest unit tests that sit beside them
#   PUBLIC dep ...             dependencies that the public headers expose
#   PRIVATE dep ...            dependencies that only the sources use
#   TEST_DEPS dep ...)         extra dependencies of the unit tests
#
# One static library per module folder, named tactres_<NAME>: the folder's
# include/tactres/<NAME>/*.h are its public headers, included as
# "tactres/<NAME>/<header>.h". Its tests become one executable,
# tactres_<NAME>_tests, registered with CTest one entry per case (label
# "unit;<NAME>"). The layering (docs/ARCHITECTURE.md) is enforced by what each
# module lists here: a module can include only what it links.
function(tactres_library name)
  cmake_parse_arguments(M "" "" "SOURCES;TESTS;PUBLIC;PRIVATE;TEST_DEPS" ${ARGN})
  add_library(tactres_${name} STATIC ${M_SOURCES})
  target_include_directories(tactres_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_link_libraries(tactres_${name} PUBLIC ${M_PUBLIC} PRIVATE ${M_PRIVATE})

  if(M_TESTS)
    add_executable(tactres_${name}_tests ${M_TESTS} ${PROJECT_SOURCE_DIR}/tests/support/doctest_main.cpp)
    target_link_libraries(tactres_${name}_tests PRIVATE tactres_${name} doctest::doctest ${M_PRIVATE} ${M_TEST_DEPS})
    target_include_directories(tactres_${name}_tests PRIVATE ${PROJECT_SOURCE_DIR}/tests/support)
    target_compile_definitions(tactres_${name}_tests PRIVATE TACTRES_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
    doctest_discover_tests(tactres_${name}_tests TEST_PREFIX "${name}: " PROPERTIES LABELS "unit;${name}")
  endif()
endfunction()

# tactres_embed_assets(TARGET HEADER asset ...)
# Web assets (CSS, JavaScript) are kept as plain files in the module's
# assets/ folder and compiled into TARGET as a generated header HEADER
# (cmake/embed_assets.cmake), rebuilt whenever an asset changes.
function(tactres_embed_assets target header)
  set(out ${CMAKE_CURRENT_BINARY_DIR}/generated/${header})
  set(files)
  foreach(asset ${ARGN})
    list(APPEND files ${CMAKE_CURRENT_SOURCE_DIR}/${asset})
  endforeach()
  # '|' separates the files on the command line: ';' would end the command.
  string(REPLACE ";" "|" file_args "${files}")
  add_custom_command(OUTPUT ${out}
    COMMAND ${CMAKE_COMMAND} -DOUT=${out} -DFILES=${file_args} -P ${PROJECT_SOURCE_DIR}/cmake/embed_assets.cmake
    DEPENDS ${files} ${PROJECT_SOURCE_DIR}/cmake/embed_assets.cmake
    COMMENT "Embedding ${header}"
    VERBATIM)
  target_sources(${target} PRIVATE ${out})
  target_include_directories(${target} PRIVATE ${CMAKE_CURRENT_BINARY_DIR}/generated)
endfunction()
