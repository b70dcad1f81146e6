# Finds liblbfgs (Debian's liblbfgs-dev), the L-BFGS the corridor_minco and ego_bspline back
# ends optimise with: the imported target Lbfgs::lbfgs, defined once whoever asks first.
find_path(LBFGS_INCLUDE_DIR lbfgs.h)
find_library(LBFGS_LIBRARY lbfgs)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(Lbfgs REQUIRED_VARS LBFGS_LIBRARY LBFGS_INCLUDE_DIR)
if(Lbfgs_FOUND AND NOT TARGET Lbfgs::lbfgs)
  add_library(Lbfgs::lbfgs UNKNOWN IMPORTED GLOBAL)
  set_target_properties(Lbfgs::lbfgs PROPERTIES IMPORTED_LOCATION "${LBFGS_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${LBFGS_INCLUDE_DIR}")
endif()
