#pragma once
// The lattice-Boltzmann stages across Open MPI processes (started by mpirun): the lattice is
// cut into slabs along y, one per process. The water model's slabs exchange one halo row of
// populations before streaming and one of densities before the force computation; the
// percolation's two refined rows of activation before each step; the lighting's the photons
// that crossed a cut after each step. Results are bit-identical to one process.
#include <memory>

#include "nephos/lbm/decomposition.hpp"

namespace nephos::lbm::mpi {

/// True when this process was started by mpirun/mpiexec with more than one process.
bool launched();

/// MPI from MPI_Init to MPI_Finalize, for the program's lifetime: active only when launched().
class Session {
 public:
  Session(int& argc, char**& argv);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
  bool active() const { return active_; }
  int rank() const;
  int size() const;

 private:
  bool active_;
};

/// The slab decomposition over every process of the active session.
std::unique_ptr<Decomposition> slabs();

}  // namespace nephos::lbm::mpi
