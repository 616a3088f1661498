"""Mission, fence and rally items: the data type, upload validation and persistent storage."""
