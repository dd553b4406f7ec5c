"""simroad.control"""
