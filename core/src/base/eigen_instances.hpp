#pragma once
// eigen_instances.hpp: explicit instantiation declarations of the dense Eigen decompositions that
// ecmor uses in many translation units, so that each is compiled once (eigen_instances_*.cpp)
// instead of once per file that uses it.
//
// Why: the build's time went to instantiating these templates, not to our own code. gcc spent
// 46 s of lyapunov.cpp's 78 s in the front end alone (template instantiation, -ftime-report), and
// the same decompositions were compiled again in about 60 other files (core, plugins, tests).
// With these declarations lyapunov.cpp took 38 s of CPU instead of 140 s in one measurement
// (docs/benchmarks.md, "Where the build's time goes").
//
// Every in-tree C++ target gets this header as a forced include (CMakeLists.txt), and every one
// links the objects that hold the definitions (ecmor_eigen_instances, through ecmor::core). The
// declarations change nothing but where the code is compiled: the same template code runs, and
// calls with other argument types (an expression instead of a matrix) are instantiated where
// they are used, as before. Out-of-tree plugins do not see this header and instantiate what they
// use themselves.
//
// Only class templates whose heavy members are defined outside the class body are listed (their
// inline members are still instantiated for inlining), with the member templates that do the work
// (compute<MatrixXd>) named one by one.
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>
#include <Eigen/SVD>

// The lists below are written once, as macros: here they expand to the declarations, and in
// eigen_instances_*.cpp, with ECMOR_EIGEN_EXTERN redefined as nothing, to the definitions (a
// definition may follow a declaration in the same file).
#define ECMOR_EIGEN_EXTERN extern

// The list is split in parts so that the definitions compile in parallel (about 20-40 s each).
// clang-format off
#define ECMOR_EIGEN_INSTANCES_EIGENVALUES                                                          \
  ECMOR_EIGEN_EXTERN template class Eigen::EigenSolver<Eigen::MatrixXd>;                           \
  ECMOR_EIGEN_EXTERN template Eigen::EigenSolver<Eigen::MatrixXd>&                                 \
  Eigen::EigenSolver<Eigen::MatrixXd>::compute<Eigen::MatrixXd>(                                   \
      const Eigen::EigenBase<Eigen::MatrixXd>&, bool);                                             \
  ECMOR_EIGEN_EXTERN template class Eigen::RealSchur<Eigen::MatrixXd>;                             \
  ECMOR_EIGEN_EXTERN template Eigen::RealSchur<Eigen::MatrixXd>&                                   \
  Eigen::RealSchur<Eigen::MatrixXd>::compute<Eigen::MatrixXd>(                                     \
      const Eigen::EigenBase<Eigen::MatrixXd>&, bool);                                             \
  ECMOR_EIGEN_EXTERN template class Eigen::ComplexSchur<Eigen::MatrixXcd>;                         \
  ECMOR_EIGEN_EXTERN template Eigen::ComplexSchur<Eigen::MatrixXcd>&                               \
  Eigen::ComplexSchur<Eigen::MatrixXcd>::compute<Eigen::MatrixXcd>(                                \
      const Eigen::EigenBase<Eigen::MatrixXcd>&, bool);                                            \
  ECMOR_EIGEN_EXTERN template class Eigen::ComplexEigenSolver<Eigen::MatrixXcd>;                   \
  ECMOR_EIGEN_EXTERN template Eigen::ComplexEigenSolver<Eigen::MatrixXcd>&                         \
  Eigen::ComplexEigenSolver<Eigen::MatrixXcd>::compute<Eigen::MatrixXcd>(                          \
      const Eigen::EigenBase<Eigen::MatrixXcd>&, bool);                                            \
  ECMOR_EIGEN_EXTERN template class Eigen::GeneralizedEigenSolver<Eigen::MatrixXd>;                \
  ECMOR_EIGEN_EXTERN template class Eigen::RealQZ<Eigen::MatrixXd>;

#define ECMOR_EIGEN_INSTANCES_SYMMETRIC                                                            \
  ECMOR_EIGEN_EXTERN template class Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>;                \
  ECMOR_EIGEN_EXTERN template Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>&                      \
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>::compute<Eigen::MatrixXd>(                        \
      const Eigen::EigenBase<Eigen::MatrixXd>&, int);                                              \
  ECMOR_EIGEN_EXTERN template class Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd>;     \
  ECMOR_EIGEN_EXTERN template class Eigen::LLT<Eigen::MatrixXd>;                                   \
  ECMOR_EIGEN_EXTERN template Eigen::LLT<Eigen::MatrixXd>&                                         \
  Eigen::LLT<Eigen::MatrixXd>::compute<Eigen::MatrixXd>(const Eigen::EigenBase<Eigen::MatrixXd>&);

#define ECMOR_EIGEN_INSTANCES_SVD                                                                  \
  ECMOR_EIGEN_EXTERN template class Eigen::JacobiSVD<Eigen::MatrixXd>;                             \
  ECMOR_EIGEN_EXTERN template class Eigen::JacobiSVD<Eigen::MatrixXcd>;                            \
  ECMOR_EIGEN_EXTERN template class Eigen::BDCSVD<Eigen::MatrixXd>;

#define ECMOR_EIGEN_INSTANCES_LU_QR                                                                \
  ECMOR_EIGEN_EXTERN template class Eigen::PartialPivLU<Eigen::MatrixXd>;                          \
  ECMOR_EIGEN_EXTERN template class Eigen::PartialPivLU<Eigen::MatrixXcd>;                         \
  ECMOR_EIGEN_EXTERN template class Eigen::FullPivLU<Eigen::MatrixXd>;                             \
  ECMOR_EIGEN_EXTERN template class Eigen::HouseholderQR<Eigen::MatrixXd>;                         \
  ECMOR_EIGEN_EXTERN template class Eigen::ColPivHouseholderQR<Eigen::MatrixXd>;                   \
  ECMOR_EIGEN_EXTERN template Eigen::ColPivHouseholderQR<Eigen::MatrixXd>&                         \
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd>::compute<Eigen::MatrixXd>(                           \
      const Eigen::EigenBase<Eigen::MatrixXd>&);
// clang-format on

ECMOR_EIGEN_INSTANCES_EIGENVALUES
ECMOR_EIGEN_INSTANCES_SYMMETRIC
ECMOR_EIGEN_INSTANCES_SVD
ECMOR_EIGEN_INSTANCES_LU_QR
