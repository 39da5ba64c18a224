"""The pygame-ce interface of the interactive study (window, views, cues, questionnaires)."""
