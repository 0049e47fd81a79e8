# tactres_module(NAME DEPS ...)
# One static library per module folder: include/tactres/<name>/*.h are the
# public headers, src/*.cpp the sources, src/*_test.cpp the doctest unit tests
# that sit beside them. Tests are registered with CTest, one entry per case.
function(tactres_module name)
  cmake_parse_arguments(M "" "" "DEPS;TEST_DEPS" ${ARGN})
  file(GLOB all_sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/src/*.cpp)
  set(sources ${all_sources})
  list(FILTER sources EXCLUDE REGEX "_test\\.cpp$")
  set(tests ${all_sources})
  list(FILTER tests INCLUDE REGEX "_test\\.cpp$")

  if(sources)
    add_library(tactres_${name} STATIC ${sources})
    target_include_directories(tactres_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
    target_link_libraries(tactres_${name} PUBLIC ${M_DEPS})
  else()  # a module still being written: headers only
    add_library(tactres_${name} INTERFACE)
    target_include_directories(tactres_${name} INTERFACE ${CMAKE_CURRENT_SOURCE_DIR}/include)
    target_link_libraries(tactres_${name} INTERFACE ${M_DEPS})
  endif()

  if(tests)
    add_executable(tactres_${name}_tests ${tests} ${PROJECT_SOURCE_DIR}/tests/support/doctest_main.cpp)
    target_link_libraries(tactres_${name}_tests PRIVATE tactres_${name} doctest::doctest ${M_TEST_DEPS})
    target_include_directories(tactres_${name}_tests PRIVATE ${PROJECT_SOURCE_DIR}/tests/support)
    target_compile_definitions(tactres_${name}_tests PRIVATE
      TACTRES_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
    doctest_discover_tests(tactres_${name}_tests TEST_PREFIX "${name}: "
      PROPERTIES LABELS "unit;${name}")
  endif()
endfunction()
