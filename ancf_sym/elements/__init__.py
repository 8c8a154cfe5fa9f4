"""Symbolic element definitions (CasADi SX). Imported only by the code generator and the tests."""
