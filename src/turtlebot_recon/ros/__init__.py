"""Message <-> core conversions; the only core package that imports rospy."""
