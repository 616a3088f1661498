"""The boat's MAVLink dialect (usv.xml, includes common.xml) and its generated pymavlink module."""
