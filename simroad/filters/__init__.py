"""simroad.filters"""
