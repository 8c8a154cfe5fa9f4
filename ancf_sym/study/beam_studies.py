"""(in progress)"""
STUDIES = []
