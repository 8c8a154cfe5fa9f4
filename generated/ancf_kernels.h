/* ancf_sym generated kernels: include this to call any of them from C. Do not edit. */
#ifndef ANCF_KERNELS_H
#define ANCF_KERNELS_H
#include "cable2d_axial_green.h"
#include "cable2d_axial_biot.h"
#include "cable2d_axial_decoupled.h"
#include "cable2d_bending.h"
#include "cable2d_gravity.h"
#include "cable2d_moment.h"
#include "cable3d_axial_green.h"
#include "cable3d_axial_biot.h"
#include "cable3d_axial_decoupled.h"
#include "cable3d_bending.h"
#include "cable3d_gravity.h"
#include "cable3d_moment.h"
#include "beam3d_continuum.h"
#include "beam3d_line_strain.h"
#include "beam3d_line_bending.h"
#include "beam3d_line_torsion.h"
#include "beam3d_gravity.h"
#include "beam3d_moment_z.h"
#include "beam3d_moment_y.h"
#include "ancf_mass.h"
#endif
