# SPDX-License-Identifier: Apache-2.0
# Core-build tests (cmake/CoreOnly.cmake): everything in the core test files except the cases that
# read GeoTIFF DEMs, write EXR/PNG, or run CLI subcommands the core CLI lacks; each of these throws
# "... is not available in the core build" there, which is the intended behaviour.
# NpyNumpy.* runs python3-numpy and the full CLI (the core cases read numpy-written fixtures).
set(TERRACL_CORE_TEST_FILTER
    "*-Gradient.CliExtractWritesATwoChannelExr:Reconstruct.RealDemRoundTripWithinTolerance:Refine.ReconstructStageGivesTheAskedAccuracyByDefault:Edit.CopyPasteHasNoStepAcrossTheBoundary:Edit.GradientImageRoundTripWithinQuantisation:NpyNumpy.*")
