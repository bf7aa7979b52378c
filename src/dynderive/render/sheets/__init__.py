"""The solution sheets: LaTeX (and PDF), HTML, the JSON dump and the terminal summary, one
renderer per format over one content model; a robot with quaternion joints gets the
quasi-velocity sections."""
