# Finds the Debian packages evermap builds against (scripts/setup.sh installs them).
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs calib3d features2d)
find_package(Threads REQUIRED)
find_package(SQLite3 REQUIRED)
# zstd (libzstd-dev): the default image encoding (core/messages/image_codec.h).
find_path(ZSTD_INCLUDE_DIR zstd.h REQUIRED)
find_library(ZSTD_LIBRARY zstd REQUIRED)
add_library(evermap_zstd INTERFACE)
target_include_directories(evermap_zstd INTERFACE ${ZSTD_INCLUDE_DIR})
target_link_libraries(evermap_zstd INTERFACE ${ZSTD_LIBRARY})

# libsodium (libsodium-dev): the MAC of the message envelope (core/messages/envelope.h).
find_package(PkgConfig REQUIRED)
pkg_check_modules(SODIUM REQUIRED IMPORTED_TARGET libsodium)

# LCM 1.3.1 ships a pkg-config file that drags in glib's; the C/C++ API needs neither.
find_path(LCM_INCLUDE_DIR lcm/lcm-cpp.hpp REQUIRED)
find_library(LCM_LIBRARY lcm REQUIRED)
find_program(LCM_GEN lcm-gen REQUIRED)
add_library(evermap_lcm INTERFACE)
target_include_directories(evermap_lcm INTERFACE ${LCM_INCLUDE_DIR})
target_link_libraries(evermap_lcm INTERFACE ${LCM_LIBRARY})

# SuiteSparse 5.x (Debian bookworm) has no CMake package: find the pieces by hand.
find_path(SUITESPARSE_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse REQUIRED)
set(_ss_libs)
foreach(lib cholmod spqr ccolamd colamd camd amd suitesparseconfig)
  find_library(SUITESPARSE_${lib}_LIBRARY ${lib} REQUIRED)
  list(APPEND _ss_libs ${SUITESPARSE_${lib}_LIBRARY})
endforeach()
add_library(evermap_suitesparse INTERFACE)
target_include_directories(evermap_suitesparse INTERFACE ${SUITESPARSE_INCLUDE_DIR})
target_link_libraries(evermap_suitesparse INTERFACE ${_ss_libs})

if(EVERMAP_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(EVERMAP_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()
if(EVERMAP_BUILD_JAVA)
  find_package(Java COMPONENTS Development)
  find_file(LCM_JAR lcm.jar PATHS /usr/share/java)
  if(NOT Java_JAVAC_EXECUTABLE OR NOT LCM_JAR)
    message(WARNING "javac or lcm.jar not found: the lcm-spy jar is not built")
    set(EVERMAP_BUILD_JAVA OFF)
  endif()
endif()

# libwebsockets (Debian's libwebsockets-dev 4.1): the viewer's HTTP and WebSocket server, through
# the package's CMake file (target websockets_shared). Without it the viewer is not built (a
# warning), so a tree set up before the viewer existed still builds everything else;
# scripts/setup.sh installs it.
find_package(libwebsockets CONFIG QUIET)
if(libwebsockets_FOUND AND TARGET websockets_shared)
  add_library(evermap_websockets INTERFACE)
  target_link_libraries(evermap_websockets INTERFACE websockets_shared)
  set(EVERMAP_HAVE_WEBSOCKETS ON)
else()
  message(WARNING "libwebsockets not found (run scripts/setup.sh): evermap-viewer is not built")
  set(EVERMAP_HAVE_WEBSOCKETS OFF)
endif()
