#pragma once
// Materials by tissue for the voxel model: which material each voxel holds, so bone is hard
// and fat soft under one tool (docs/physics.md, "Materials by tissue").
//
// A TissueMap is a table of materials and an integer grid over the density field's index
// space whose value at a voxel is the voxel's row in the table (its "slot"). The grid's
// background, 0, selects row 0: the material of every voxel no label gave one (the
// command's own E, nu and sigma_f), which is also what sculpted material flowing into an
// unlabelled voxel is made of. ToolForceModel reads it at each surface quadrature point
// (tool_force.h); builders from labels and a materials file live in engine/labels/tissue.h.
//
// Constant after construction and shared by threads; each thread reads the slots through
// its own accessor (ToolForceState).

#include <openvdb/openvdb.h>

#include <string>
#include <vector>

#include "engine/material.h"

namespace hapvox::engine {

struct TissueMaterial {
  std::string name;  // for reports ("" when none)
  ElasticMaterial elastic;
  double yield_stress_pa = 10e3;  // sigma_f, for plasticity
};

class TissueMap {
 public:
  /// One row of the table as the force loop reads it: Lame parameters, E, nu, sigma_f.
  struct Row {
    double lambda_pa = 0.0;
    double mu_pa = 0.0;
    double youngs_modulus_pa = 0.0;
    double poisson_ratio = 0.0;
    double yield_stress_pa = 0.0;
  };

  /// `slots` must hold values in [0, materials.size()) (CHECKed) with background 0, over the
  /// same index grid as the density field it is used with. Throws InputError("tissue", ...)
  /// for an invalid material (E, nu) or a yield stress that is not positive and finite.
  TissueMap(std::vector<TissueMaterial> materials, openvdb::Int32Grid::Ptr slots);

  const std::vector<TissueMaterial>& materials() const { return materials_; }
  const std::vector<Row>& rows() const { return rows_; }
  const openvdb::Int32Grid& slots() const { return *slots_; }
  /// The slot of voxel `ijk` (0 where no voxel was given one).
  int slot_at(const openvdb::Coord& ijk) const;
  /// Smallest Young's modulus of the table (plasticity needs E_ep below every E).
  double min_youngs_modulus_pa() const;

 private:
  std::vector<TissueMaterial> materials_;
  std::vector<Row> rows_;
  openvdb::Int32Grid::Ptr slots_;
};

}  // namespace hapvox::engine
