#include "lookboth/core/threads.h"

#include <dlfcn.h>

namespace lookboth {

bool serialiseOpenMpInThisThread() {
  using SetInt = void (*)(int);
  // Looked up once: the runtime (libgomp) is loaded with CHOLMOD, before main.
  static const SetInt set_num_threads =
      reinterpret_cast<SetInt>(dlsym(RTLD_DEFAULT, "omp_set_num_threads"));
  static const SetInt set_dynamic =
      reinterpret_cast<SetInt>(dlsym(RTLD_DEFAULT, "omp_set_dynamic"));
  if (set_num_threads == nullptr || set_dynamic == nullptr) return false;
  set_num_threads(1);
  set_dynamic(1);
  return true;
}

}  // namespace lookboth
