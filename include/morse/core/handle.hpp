// morse/core/handle.hpp: move-only RAII handles around PETSc/SLEPc objects.
//
// Unique<Mat, MatDestroy> owns one reference to a Mat; copy is deleted, move transfers
// ownership, get() lends the raw object, ptr() gives the address for Create functions.
// Destructors never throw. All handles must die before Session (see session.hpp) finalizes.
#pragma once

#include <petscdm.h>
#include <petscis.h>
#include <petscksp.h>
#include <petscmat.h>
#include <petscvec.h>
#include <petscviewer.h>
#include <slepceps.h>

#include <utility>

namespace morse {

template <class T, PetscErrorCode (*Destroy)(T*)>
class Unique {
 public:
  Unique() = default;
  explicit Unique(T obj) : obj_(obj) {}
  Unique(const Unique&) = delete;
  Unique& operator=(const Unique&) = delete;
  Unique(Unique&& o) noexcept : obj_(std::exchange(o.obj_, nullptr)) {}
  Unique& operator=(Unique&& o) noexcept {
    if (this != &o) {
      reset();
      obj_ = std::exchange(o.obj_, nullptr);
    }
    return *this;
  }
  ~Unique() { reset(); }

  T get() const { return obj_; }
  /// Address for PETSc Create functions; releases any object held.
  T* ptr() {
    reset();
    return &obj_;
  }
  T release() { return std::exchange(obj_, nullptr); }
  explicit operator bool() const { return obj_ != nullptr; }
  void reset() {
    if (obj_) (void)Destroy(&obj_);
    obj_ = nullptr;
  }

 private:
  T obj_ = nullptr;
};

using UMat = Unique<Mat, MatDestroy>;
using UVec = Unique<Vec, VecDestroy>;
using UIS = Unique<IS, ISDestroy>;
using UKSP = Unique<KSP, KSPDestroy>;
using UEPS = Unique<EPS, EPSDestroy>;
using UViewer = Unique<PetscViewer, PetscViewerDestroy>;

}  // namespace morse
