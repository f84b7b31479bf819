// Threads of the libraries the project calls.
#pragma once

namespace lookboth {

/// Makes the OpenMP parallel regions that the calling thread starts from now
/// on run on that one thread, when an OpenMP runtime is loaded in the process;
/// returns whether one is.
///
/// Why: CHOLMOD (SuiteSparse 5.12 in Debian 12), Ceres' sparse Cholesky
/// factorisation, runs small loops of every supernodal factorisation in
/// OpenMP teams of a compile-time 4 threads (`num_threads(CHOLMOD_OMP_NUM_THREADS)`,
/// which OMP_NUM_THREADS does not override). On a 2-core machine each
/// factorisation then wakes and waits for 3 spinning threads: `joint` on the
/// 43-camera `paper` spent a fifth of its samples in the kernel's futex calls
/// and libgomp, and the registration ran 1.7x longer (doc/benchmarks-history.md,
/// "CHOLMOD's OpenMP threads"). This sets the
/// calling thread's OpenMP ICVs nthreads-var to 1 and dyn-var to true, with
/// which libgomp caps any num_threads clause at nthreads-var. The runtime's
/// functions are looked up in the process (dlsym), so nothing links OpenMP
/// and a CHOLMOD without OpenMP makes this a no-op. Cheap: call it before
/// each sparse solve, on the thread that solves.
bool serialiseOpenMpInThisThread();

}  // namespace lookboth
