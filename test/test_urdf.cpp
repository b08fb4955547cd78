// The package's URDFs against the head geometry the simulator and the
// evaluation use (config/head.yaml, config/head_spin.yaml): with the neck at
// zero, the laser's pose from the URDF's chain is the geometry's at every
// joint angle, and the grouper's chain (tiltChainFromUrdf) finds the joint.
#include <gtest/gtest.h>

#include <urdf/model.h>

#include "tilt_laser_perception/ros/conversions.hpp"
#include "tilt_laser_perception/sim/head.hpp"
#include "tilt_laser_perception/sim/scene.hpp"

using namespace tilt_laser_perception;

namespace {
// base_footprint to `link` through the joints' origins (every joint at zero).
Eigen::Isometry3d fromBase(const urdf::Model& m, std::string link) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  while (link != "base_footprint") {
    const urdf::LinkConstSharedPtr l = m.getLink(link);
    if (!l || !l->parent_joint) throw std::runtime_error("no chain from base_footprint to " + link);
    T = toIsometry(l->parent_joint->parent_to_joint_origin_transform) * T;
    link = l->parent_joint->parent_link_name;
  }
  return T;
}

void expectSameLaser(const std::string& urdf_file, const std::string& yaml, const std::string& joint) {
  urdf::Model model;
  ASSERT_TRUE(model.initFile(std::string(TLP_SOURCE_DIR) + "/urdf/" + urdf_file)) << urdf_file;
  core::TiltChain chain;
  std::string parent, error;
  ASSERT_TRUE(tiltChainFromUrdf(model, joint, "laser", chain, parent, error)) << error;
  chain.base_to_joint = fromBase(model, parent) * chain.base_to_joint;
  const sim::HeadGeometry head = sim::HeadGeometry::load(sim::configDirectory() + "/" + yaml);
  for (double q : {-2.5, -1.0, 0.0, 0.3, 1.2, 3.0}) {
    const Eigen::Isometry3d a = chain.laserPose(q), b = head.laserPose(q);
    EXPECT_LT((a.translation() - b.translation()).norm(), 1e-6) << urdf_file << " at " << q;
    EXPECT_LT(Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle(), 1e-6) << urdf_file << " at " << q;
  }
}
}  // namespace

TEST(Urdf, TheNoddingHeadIsHeadYaml) { expectSameLaser("hrp4_head.urdf", "head.yaml", "head_tilt_joint"); }

TEST(Urdf, TheSpinningHeadIsHeadSpinYaml) {
  expectSameLaser("hrp4_head_spin.urdf", "head_spin.yaml", "head_spin_joint");
}
