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
