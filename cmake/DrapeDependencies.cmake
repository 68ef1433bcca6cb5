# Every third-party dependency, found once from Debian 12 packages (see setup.sh).
# Targets link only what they use.

find_package(Threads REQUIRED)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)             # Eigen3::Eigen
find_package(nlohmann_json 3 REQUIRED)                  # nlohmann_json::nlohmann_json
find_package(OpenSSL REQUIRED)                          # OpenSSL::Crypto (SHA-256)
find_package(OpenCV REQUIRED core imgproc imgcodecs)    # ${OpenCV_LIBS}
find_package(assimp REQUIRED)                           # assimp::assimp
find_package(CGAL REQUIRED)                             # CGAL::CGAL
# CMake's FindBullet: the CONFIG package gives relative paths.
find_package(Bullet REQUIRED MODULE)                    # ${BULLET_INCLUDE_DIRS} ${BULLET_LIBRARIES}
find_package(embree 3 REQUIRED)                         # embree
find_package(TBB REQUIRED)                              # TBB::tbb
list(APPEND CMAKE_MODULE_PATH /usr/lib/x86_64-linux-gnu/cmake/OpenVDB)
find_package(OpenVDB REQUIRED)                          # OpenVDB::openvdb
find_package(yaml-cpp REQUIRED)                         # yaml-cpp
find_package(SQLite3 REQUIRED)                          # SQLite::SQLite3
find_package(dlib REQUIRED)                             # dlib::dlib
find_package(SUNDIALS 6.4 REQUIRED)                     # SUNDIALS::kinsol, ::nvecserial, ::sunlinsoldense
find_package(CLI11 2.1 CONFIG REQUIRED)                 # CLI11::CLI11 (the drape command line)
if(DRAPE_WITH_MPI)
  find_package(MPI COMPONENTS CXX)                      # MPI::MPI_CXX
endif()
if(DRAPE_BUILD_TESTS)
  find_package(GTest REQUIRED)                          # GTest::gtest_main
endif()
if(DRAPE_BUILD_BENCH)
  find_package(benchmark REQUIRED)                      # benchmark::benchmark
endif()

# Bullet as an imported target so stages can link it like the others.
if(NOT TARGET Drape::Bullet)
  add_library(Drape::Bullet INTERFACE IMPORTED)
  set_target_properties(Drape::Bullet PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${BULLET_INCLUDE_DIRS}"
    INTERFACE_LINK_LIBRARIES "${BULLET_LIBRARIES}")
endif()
if(NOT TARGET Drape::OpenCV)
  add_library(Drape::OpenCV INTERFACE IMPORTED)
  set_target_properties(Drape::OpenCV PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${OpenCV_INCLUDE_DIRS}"
    INTERFACE_LINK_LIBRARIES "${OpenCV_LIBS}")
endif()
