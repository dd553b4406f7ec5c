"""simroad.detector"""
