// Sanitizer defaults of the test binaries in the sanitizer build (-DKINOLAB_SANITIZE=ON; the
// sanitizers call these hooks at start, however the tests are run).
//
// Full stacks at every allocation: Debian's OMPL is built without frame pointers, and the
// fast unwinder stops at its first frame, so a leak's stack would not reach the names the
// suppressions match.
extern "C" const char* __asan_default_options() { return "fast_unwind_on_malloc=0"; }

// Leaks inside third-party libraries, not kinolab's:
// - OMPL's LazyPRM::solve clones states it never frees (ompl/ompl#833, CVE-2021-41490, fixed
//   upstream by ompl/ompl#909; Debian 12's OMPL 1.6 still has it): `ompl_geometric` with
//   planner lazyprmstar.
// - OMPL's SST loses motions and witnesses it allocates in solve() ("direct" leaks: nothing
//   points to them while the planner is alive, so it is not a planner kinolab keeps), with
//   Debian 12's OMPL 1.6: `ompl_control` with planner sst.
extern "C" const char* __lsan_default_suppressions() {
  return "leak:ompl::geometric::LazyPRM::solve\n"
         "leak:ompl::control::SST::solve\n"
         "leak:ompl::control::SST::findClosestWitness\n";
}
