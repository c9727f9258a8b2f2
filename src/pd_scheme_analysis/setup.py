"""Build script of the pd_scheme_analysis ament_python package."""

from setuptools import find_packages, setup

PACKAGE = 'pd_scheme_analysis'

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
    description=('Stability and accuracy of the integration schemes: spectral radius, '
                 'numerical damping and period error sweeps, with their table and figures.'),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'analyze = pd_scheme_analysis.analyze:main',
        ],
        'pd.commands': [
            'analyze = pd_scheme_analysis.commands:ANALYZE',
        ],
    },
)
