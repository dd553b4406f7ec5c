"""simroad.noise"""
