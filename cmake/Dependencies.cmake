# Every dependency comes from Debian's archive (scripts/install-deps.sh).
# Nothing is downloaded at build time.
find_package(OpenCV REQUIRED COMPONENTS core imgproc videoio highgui)
find_package(Ceres REQUIRED)
find_package(OpenImageIO REQUIRED)
find_package(fmt REQUIRED)
find_package(doctest REQUIRED)
find_package(CLI11 REQUIRED)
find_package(nlohmann_json REQUIRED)
find_package(Threads REQUIRED)

# mrcal ships no CMake config: locate header and library by hand.
find_path(MRCAL_INCLUDE_DIR mrcal/mrcal.h REQUIRED)
find_library(MRCAL_LIBRARY mrcal REQUIRED)
add_library(mrcal::mrcal UNKNOWN IMPORTED)
set_target_properties(mrcal::mrcal PROPERTIES
  IMPORTED_LOCATION "${MRCAL_LIBRARY}"
  INTERFACE_INCLUDE_DIRECTORIES "${MRCAL_INCLUDE_DIR}")

# Tesseract (OCR of a chart's printed numbers, metrology/labels) ships a
# pkg-config file but no CMake config.
find_package(PkgConfig REQUIRED)
pkg_check_modules(Tesseract REQUIRED IMPORTED_TARGET tesseract)
