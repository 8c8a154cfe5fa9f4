"""ancf_sym"""
