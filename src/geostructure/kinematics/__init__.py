"""What can slide or topple out of the slope: the kinematic tests, wedges, the slope, the summary."""
