# The review page's files go into the program (engine/run/review_assets.cpp, .incbin). three.js comes
# from npm (scripts/setup.sh: npm ci in web/review); without it, `--report` says how to get it.
set(MOCAP_REVIEW_DIR ${CMAKE_SOURCE_DIR}/web/review)
set(MOCAP_REVIEW_THREE_JS ${MOCAP_REVIEW_DIR}/node_modules/three/build/three.module.min.js)
set(MOCAP_REVIEW_FILES ${MOCAP_REVIEW_DIR}/review.html ${MOCAP_REVIEW_DIR}/review.js)
set(MOCAP_REVIEW_DEFINITIONS MOCAP_REVIEW_TEMPLATE="${MOCAP_REVIEW_DIR}/review.html"
                             MOCAP_REVIEW_SCRIPT="${MOCAP_REVIEW_DIR}/review.js")
if(EXISTS ${MOCAP_REVIEW_THREE_JS})
  list(APPEND MOCAP_REVIEW_DEFINITIONS MOCAP_REVIEW_THREE="${MOCAP_REVIEW_THREE_JS}")
  list(APPEND MOCAP_REVIEW_FILES ${MOCAP_REVIEW_THREE_JS})
  set(MOCAP_REVIEW_HAS_THREE ON)
else()
  message(STATUS "three.js not found in ${MOCAP_REVIEW_DIR}/node_modules: --report will say so "
                 "(scripts/setup.sh installs it with npm)")
  set(MOCAP_REVIEW_HAS_THREE OFF)
endif()
set_source_files_properties(${CMAKE_SOURCE_DIR}/engine/run/review_assets.cpp PROPERTIES
  COMPILE_DEFINITIONS "${MOCAP_REVIEW_DEFINITIONS}" OBJECT_DEPENDS "${MOCAP_REVIEW_FILES}")
# The clips' motion is deflated for the page (engine/run/review_report.cpp).
find_package(ZLIB REQUIRED)
target_link_libraries(mocap_engine PRIVATE ZLIB::ZLIB)
