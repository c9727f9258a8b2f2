"""Build script of the pd_studies ament_python package."""

from setuptools import find_packages, setup

PACKAGE = 'pd_studies'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Pseudo-dynamic testing maintainers',
    maintainer_email='maintainers@pseudodynamic.dev',
    description=("The thesis's studies: the chapter 5 comparison and the growth of "
                 'experimental errors (Shing and Mahin), run offline.'),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'study_ch5 = pd_studies.study_ch5:main',
            'study_errors = pd_studies.study_errors:main',
        ],
        'pd.commands': [
            'study_ch5 = pd_studies.commands:STUDY_CH5',
            'study_errors = pd_studies.commands:STUDY_ERRORS',
        ],
    },
)
