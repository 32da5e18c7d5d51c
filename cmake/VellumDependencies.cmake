# Every dependency comes from a Debian 12 package (scripts/setup.sh installs them).
# Heavy ones (VTK, CGAL, OpenVDB, OpenMesh, GDCM) are only linked PRIVATE into the module that
# needs them, and their headers stay inside .cpp files.
find_package(Threads REQUIRED)
find_package(TBB REQUIRED)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(nlohmann_json REQUIRED)
find_package(CLI11 REQUIRED)
find_package(ZLIB REQUIRED)
find_package(PkgConfig REQUIRED)

set(OpenGL_GL_PREFERENCE GLVND)
find_package(OpenGL REQUIRED COMPONENTS OpenGL EGL)
find_package(glfw3 3.3 REQUIRED)
pkg_check_modules(IMGUI REQUIRED IMPORTED_TARGET imgui)
# gzip for NRRD data (io only): ISA-L compresses (Debian libisal-dev), libdeflate decompresses
# whole buffers (Debian libdeflate-dev); zlib names what is wrong with a bad stream.
pkg_check_modules(LIBDEFLATE REQUIRED IMPORTED_TARGET libdeflate)
pkg_check_modules(LIBISAL REQUIRED IMPORTED_TARGET libisal)

find_package(GDCM REQUIRED)
find_package(OpenCV REQUIRED COMPONENTS core imgproc imgcodecs videoio)
find_package(VTK REQUIRED COMPONENTS CommonCore CommonDataModel CommonTransforms
             ImagingCore ImagingGeneral IOImage IOXML IOLegacy IOGeometry FiltersCore FiltersGeneral)

# OpenVDB ships only a Find module (see docs/build-notes).
list(APPEND CMAKE_MODULE_PATH /usr/lib/x86_64-linux-gnu/cmake/OpenVDB)
find_package(OpenVDB REQUIRED)
find_package(OpenMesh REQUIRED CONFIG)
find_package(CGAL REQUIRED)

if(VELLUM_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(VELLUM_BUILD_BENCHMARKS)
  find_package(benchmark REQUIRED)
endif()
